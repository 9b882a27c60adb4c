"""Bring-up and tear-down as plans: from the empty configuration to the deployed one, and back.

Nothing running is a configuration like any other (no component, so no assumption to hold): a
system started by `reconf up` is created, attached and upgraded in an order that keeps every
state valid, and `reconf down` takes it apart the same way, each plan verified like any other
(docs/executor.md#bring-up-and-tear-down).
"""
from __future__ import annotations

from dataclasses import replace as dc_replace
from typing import Optional

from checker.planning.chain import Fallback
from checker.planning.operations import plan_problem
from checker.planning.plan import Goal, Plan, Problem, settle
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System

__all__ = ["EMPTY", "up_problem", "up_state", "down_problem", "plan_up", "plan_down"]

EMPTY = Configuration(frozenset(), frozenset(), frozenset())


def up_problem(system: System) -> Problem:
    """From nothing to `system`'s deployed configuration: every deployed component is created
    (it is a version of the empty system), the versions it declares stay declared."""
    target = Configuration.initial(system)
    empty = dc_replace(system, components=(), versions=system.components + system.versions)
    return Problem(empty, EMPTY, Goal(target.components, target.roles, target.degraded),
                   added=[c.name for c in system.components])


def up_state(system: System) -> Configuration:
    """What `reconf up` brings about: the deployed configuration with the functionalities whose
    assumptions cannot hold there left degraded (`settle`)."""
    target = Configuration.initial(system)
    return settle(system, Goal(target.components, target.roles)).config


def down_problem(system: System) -> Problem:
    """From what `reconf up` brought about (`up_state`) to nothing."""
    return Problem(system, up_state(system), Goal(frozenset(), frozenset(), frozenset()),
                   removed=[c.name for c in system.components])


def plan_up(system: System, strategy: str = "default", fallback: Optional[Fallback] = None) -> Plan:
    return plan_problem(up_problem(system), strategy, fallback)


def plan_down(system: System, strategy: str = "default", fallback: Optional[Fallback] = None) -> Plan:
    return plan_problem(down_problem(system), strategy, fallback)
