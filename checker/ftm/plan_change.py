"""A change from one architecture to another, planned: the one entry point of `reconf plan
migrate`, `reconf gate` and `reconf graph-plan`.

Where either architecture attaches a fault-tolerance mechanism, the change is planned on their
expansions (docs/ftm.md): the nodes that differ change, the protocols around them are suspended
meanwhile, and the rest is kept. Otherwise it is planned through the fallback chain
(`checker.planning.chain`)."""
from __future__ import annotations

from typing import Optional

from checker.ftm.expand import expand
from checker.ftm.transition import plan_ftm_migrate
from checker.planning import Fallback, Plan, plan_migrate
from reconf_dsl.ir import System


def has_ftm(*systems: System) -> bool:
    return any(c.ftm is not None for s in systems for c in s.components)


def planned_on(old: System, new: System) -> tuple[System, System]:
    """The architectures a change from `old` to `new` is planned between: their expansions
    where either has an FTM, else themselves."""
    if has_ftm(old, new):
        return expand(old)[0], expand(new)[0]
    return old, new


def plan_change(old: System, new: System, strategy: str = "default",
                fallback: Optional[Fallback] = None) -> Plan:
    """The plan from `old` to `new`; raises NoSafePlan (NoPlanFound through the chain). With
    FTMs, `strategy` alone plans (the fallback chain is for plans on the architectures as written)."""
    if has_ftm(old, new):
        return plan_ftm_migrate(old, new, strategy).plan
    return plan_migrate(old, new, strategy, fallback=fallback)
