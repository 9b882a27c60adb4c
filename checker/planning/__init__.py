"""Planning safe reconfigurations as sequences of the six actions (DESIGN.md §7).

Strategies: `paper` (Algorithm 1 of paper 001), `default` (make before break, least
disruption found without search), `exhaustive` (A*, optimal). See each module.
"""
from .operations import STRATEGIES, plan_add, plan_migrate, plan_remove, plan_replace, solve
from .plan import BadRequest, Goal, NoSafePlan, Plan, Problem, disruption, verify

__all__ = ["STRATEGIES", "BadRequest", "Goal", "NoSafePlan", "Plan", "Problem", "disruption", "plan_add", "plan_migrate",
           "plan_remove", "plan_replace", "solve", "verify"]
