"""Resuming a mechanism's watchers last: a plan that upgrades a crash detector (and the recovery
its alarm drives) while the request path is still degraded arms it before the queue the
suspension built reaches the primary. Draining that queue keeps the primary's host busy for
longer than the detector's silence limit, which then takes it for crashed: the backup takes over
and the primary fences itself, in the middle of the plan. A transition resumes them last
(checker/ftm/transition.py); `watchers_last` gives any plan on an expanded system, a recovery's
above all, the same order where every state stays valid (docs/ftm.md#resuming-the-watchers-last)."""
from __future__ import annotations

from checker.ftm.expand import ALARM, BEAT
from checker.planning import NoSafePlan, Plan
from checker.planning.plan import verify
from checker.semantic_model.actions import Upgrade
from checker.semantic_model.config import FuncId
from reconf_dsl import ir

__all__ = ["watchers_last", "watchers"]

NOTE = ("the crash detectors and the recovery they alarm are resumed last, once the request path "
        "serves again (docs/ftm.md#resuming-the-watchers-last)")


def watchers(system: ir.System) -> set[FuncId]:
    """The functionalities that act on a silence or on its alarm: those whose normal mode assumes
    heartbeats at a rate (a crash detector) or alarms (a recovery)."""
    def watching(a: ir.Predicate) -> bool:
        return a.message == ALARM.message or (a.message == BEAT.message and a.rate is not None)
    return {(c.name, f.name) for c in system.components + system.versions for f in c.functionalities
            if f.normal is not None and any(watching(a) for a in f.normal.assumptions)}


def watchers_last(plan: Plan) -> Plan:
    """`plan` with its upgrades of watchers moved to its end, in their order, when the result is
    valid in every state (verified as any plan); else `plan` as it is."""
    watching = watchers(plan.system)
    moved = [a for a in plan.steps if isinstance(a, Upgrade) and (a.component, a.functionality) in watching]
    if not moved or plan.steps[-len(moved):] == moved:
        return plan
    steps = [a for a in plan.steps if a not in moved] + moved
    try:
        out = verify(plan.system, plan.states[0], steps, plan.goal, plan.strategy, dict(plan.renames))
    except NoSafePlan:
        return plan
    out.notes = plan.notes + [n for n in out.notes if n not in plan.notes] + [NOTE]
    out.attempts = list(plan.attempts)
    return out
