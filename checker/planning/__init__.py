"""Planning safe reconfigurations as sequences of the six actions (docs/design.md#planning).

Strategies: `paper` (Algorithm 1 of paper 001), `default` (make before break, least
disruption found without search), `exhaustive` (decides whether a plan exists; A* for the
optimum). See each module; `chain` goes from one to the next when one fails.
"""
from checker.planning.chain import Attempt, Fallback, NoPlanFound, plan_with_fallback
from checker.planning.operations import plan_add, plan_migrate, plan_remove, plan_replace
from checker.planning.plan import BadRequest, Goal, NoSafePlan, Plan, Problem, disruption, verify
from checker.planning.strategies import STRATEGIES, solve

__all__ = ["STRATEGIES", "Attempt", "BadRequest", "Fallback", "Goal", "NoPlanFound", "NoSafePlan", "Plan", "Problem",
           "disruption", "plan_add", "plan_migrate", "plan_remove", "plan_replace", "plan_with_fallback", "solve",
           "verify"]
