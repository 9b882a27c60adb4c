"""Recovery: plan from an observed configuration (a failed run's report) to a target.

The observed configuration may be invalid (a node died): the plan then starts by degrading,
as `settle` finds them, the functionalities whose assumptions fail; a degraded mode assumes
nothing, so those steps only take away what the running system no longer has. From there
it is an ordinary plan, verified step by step (docs/executor.md#failure-and-recovery).
"""
from __future__ import annotations

from dataclasses import replace as dc_replace

from checker.model.actions import Degrade, effect
from checker.model.config import Configuration
from checker.planning.plan import Goal, Plan, Problem, disruption, settle
from checker.planning.states import States
from checker.planning.strategies import solve
from reconf_dsl.ir import System

__all__ = ["plan_recovery"]


def plan_recovery(system: System, observed: Configuration, target: Configuration,
                  strategy: str = "default") -> Plan:
    settled = settle(system, Goal(observed.components, observed.roles, observed.degraded))
    emergency = [Degrade(c, f) for c, f in sorted(settled.degraded - observed.degraded)]
    start = observed
    for a in emergency:
        start = effect(system, start, a)     # valid at the end: settle degrades until nothing fails
    goal = Goal(target.components, target.roles, target.degraded)
    deployed = tuple(c for c in system.components + system.versions if c.name in start.components)
    rest = tuple(c for c in system.components + system.versions if c.name not in start.components)
    base = dc_replace(system, components=deployed, versions=rest)
    plan = solve(Problem(base, start, goal), strategy)
    if not emergency:
        return plan
    steps = list(emergency) + plan.steps
    all_states = States(base, observed, steps)
    first = "step 1 degrades" if len(emergency) == 1 else f"steps 1-{len(emergency)} degrade"
    notes = [f"the observed configuration is not valid: {first} what fails in it"] + plan.notes
    return Plan(base, steps, all_states, plan.strategy, disruption(base, all_states, steps), plan.goal,
                plan.renames, notes, plan.verification)
