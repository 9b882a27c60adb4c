"""Planning safe reconfigurations as sequences of the six actions (docs/design.md#planning).

Strategies: `paper` (Algorithm 1 of paper 001), `default` (make before break, least
disruption found without search), `exhaustive` (decides whether a plan exists; A* for the
optimum). See each module; `chain` goes from one to the next when one fails.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from checker.exports import lazy

if TYPE_CHECKING:
    from checker.planning.chain import Attempt, Fallback, NoPlanFound, plan_with_fallback
    from checker.planning.operations import plan_add, plan_migrate, plan_remove, plan_replace
    from checker.planning.plan import BadRequest, Goal, NoSafePlan, Plan, Problem, disruption, verify
    from checker.planning.strategies import STRATEGIES, solve

# loaded on first use (checker.exports.lazy): a check imports no planner
__all__, __getattr__ = lazy(__name__, {
    "chain": ("Attempt", "Fallback", "NoPlanFound", "plan_with_fallback"),
    "operations": ("plan_add", "plan_migrate", "plan_remove", "plan_replace"),
    "plan": ("BadRequest", "Goal", "NoSafePlan", "Plan", "Problem", "disruption", "verify"),
    "strategies": ("STRATEGIES", "solve"),
})
