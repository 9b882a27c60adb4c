"""Reconfigurations to plan: replace, remove, add, migrate, each as a `Problem` planned by a
strategy (`checker.planning.strategies`) or through the fallback chain.

Every plan is checked step by step with `semantics.evaluate` (`plan.verify`) before it is
returned. Each `plan_*` plans with the strategy it is given alone, or, given a `Fallback`,
goes on to the next strategies when that one fails (`checker.planning.chain`). A `migrate`
is described on one combined System: the old deployed components, and as versions the new
ones. A component whose definition changed becomes a new version named `<name>@new` (and a
connector whose definition changed, `<name>@new`); `Plan.renames` maps these back to the
names of the new architecture. Environment guarantees are those of the old architecture.

A target need not have every functionality normal: the goal is `settle`d first, so the
functionalities whose assumptions cannot hold in the target (removing the only publisher of
a topic they need, say) end degraded, and the plan's notes say which and why. Only a target
that no degradation makes valid (two publishers on a `single` topic) is refused.
"""
from __future__ import annotations

from dataclasses import replace as dc_replace
from typing import Optional, Union

from checker.planning.chain import Fallback, plan_with_fallback
from checker.planning.environment import missing_environment
from checker.planning.plan import BadRequest, Goal, NoSafePlan, Plan, Problem, unknown
from checker.planning.strategies import solve
from checker.semantic_model.config import Configuration, Role
from reconf_dsl.ir import Component, Connector, System

__all__ = ["plan_problem", "plan_replace", "plan_remove", "plan_add", "plan_migrate", "replace_problem",
           "remove_problem"]

RENAMED = "@new"


class _NoPort:
    kind = "none"


_NO_PORT = _NoPort()


def plan_problem(problem: Problem, strategy: str, fallback: Optional[Fallback]) -> Plan:
    """`strategy` alone, or with `fallback` the next strategies when it fails (`chain`)."""
    if fallback is None:
        return solve(problem, strategy)
    return plan_with_fallback(problem, strategy, fallback)


def _start(system: System, config: Optional[Configuration]) -> Configuration:
    return config if config is not None else Configuration.initial(system)


def replace_problem(system: System, old: str, new: Union[str, Component],
                    config: Optional[Configuration] = None) -> Problem:
    """Replacing deployed `old` by the version `new` (a name in `system.versions`, or a Component)."""
    if isinstance(new, Component):
        if system.component(new.name) is None:
            system = dc_replace(system, versions=system.versions + (new,))
        new = new.name
    start = _start(system, config)
    if old not in start.components:
        raise unknown("deployed component", old, start.components, system.name)
    comp = system.component(new)
    if comp is None:
        raise unknown("declared component", new, [c.name for c in system.versions], system.name)
    if new == old:
        raise BadRequest(f"{old} cannot replace itself: name a new version of it")
    if new in start.components:
        raise BadRequest(f"{new} is deployed already: a replacement is a new version of {old} "
                         f"(declared `component {new} replaces {old}`, or taken from another file)")
    if comp.replaces not in (None, old):
        raise BadRequest(f"{new} is declared as a new version of {comp.replaces}, not of {old}")
    roles = {r for r in start.roles if r[1] != old}
    roles |= {(conn, new, port) for conn, c, port in start.roles if c == old and comp.port(port) is not None}
    goal = Goal((start.components - {old}) | {new}, frozenset(roles))
    return Problem(system, start, goal, replaced=[(old, new)])


def plan_replace(system: System, old: str, new: Union[str, Component], strategy: str = "default",
                 config: Optional[Configuration] = None, fallback: Optional[Fallback] = None) -> Plan:
    """Replace deployed `old` by the version `new` (see `replace_problem`)."""
    return plan_problem(replace_problem(system, old, new, config), strategy, fallback)


def remove_problem(system: System, component: str, config: Optional[Configuration] = None) -> Problem:
    """Removing deployed `component`, with its attachments."""
    start = _start(system, config)
    if component not in start.components:
        raise unknown("deployed component", component, start.components, system.name)
    goal = Goal(start.components - {component}, frozenset(r for r in start.roles if r[1] != component))
    return Problem(system, start, goal, removed=[component])


def plan_remove(system: System, component: str, strategy: str = "default",
                config: Optional[Configuration] = None, fallback: Optional[Fallback] = None) -> Plan:
    return plan_problem(remove_problem(system, component, config), strategy, fallback)


def plan_add(system: System, component: str, strategy: str = "default", *, source: System,
             config: Optional[Configuration] = None, fallback: Optional[Fallback] = None) -> Plan:
    """Add `component` as `source` declares it, with its attachments there."""
    comp = source.component(component)
    if comp is None:
        raise unknown("component", component, [c.name for c in source.components], source.name)
    if system.component(component) is not None:
        raise BadRequest(f"{system.name} already declares a component {component}: add a new one, or replace it")
    roles = {(conn.name, r.component, r.port) for conn in source.connectors for r in conn.roles
             if r.component == component}
    missing = [dc_replace(conn, publishers=(), subscribers=()) for conn in source.connectors
               if conn.name in {r[0] for r in roles} and system.connector(conn.name) is None]
    system = dc_replace(system, versions=system.versions + (comp,), connectors=system.connectors + tuple(missing))
    start = _start(system, config)
    goal = Goal(start.components | {component}, start.roles | roles)
    return plan_problem(Problem(system, start, goal, added=[component]), strategy, fallback)


def plan_migrate(old: System, new: System, strategy: str = "default",
                 config: Optional[Configuration] = None, fallback: Optional[Fallback] = None) -> Plan:
    """From the deployed `old` architecture to the deployed `new` one, in `old`'s environment."""
    needs = missing_environment(old, new, old.name, new.name)
    if needs:
        raise NoSafePlan(needs)
    olds = {c.name: c for c in old.components}
    news = {c.name: c for c in new.components}
    taken = {c.name for c in old.components + old.versions}
    comp_names: dict[str, str] = {}
    versions = list(old.versions)
    replaced, added = [], []
    for name, c in news.items():
        if name in olds and _same_component(olds[name], c):
            comp_names[name] = name
            continue
        target = name if name not in taken else _fresh(name, taken)
        taken.add(target)
        comp_names[name] = target
        versions.append(dc_replace(c, name=target, replaces=name if name in olds else c.replaces))
        (replaced.append((name, target)) if name in olds else added.append(target))
    removed = [n for n in olds if n not in news]
    old_conns = {c.name: c for c in old.connectors}
    conn_names: dict[str, str] = {}
    conns = list(old.connectors)
    conn_taken = set(old_conns)
    for conn in new.connectors:
        if conn.name in old_conns and _same_connector(old_conns[conn.name], conn):
            conn_names[conn.name] = conn.name
            continue
        target = conn.name if conn.name not in conn_taken else _fresh(conn.name, conn_taken)
        conn_taken.add(target)
        conn_names[conn.name] = target
        conns.append(dc_replace(conn, name=target, publishers=(), subscribers=()))
    # the message types the new architecture adds: its new components' ports carry them
    known = {m.name for m in old.messages}
    messages = old.messages + tuple(m for m in new.messages if m.name not in known)
    system = dc_replace(old, messages=messages, versions=tuple(versions), connectors=tuple(conns))
    start = _start(old, config)
    roles: set[Role] = {(conn_names[conn.name], comp_names[r.component], r.port) for conn in new.connectors
                        for r in conn.roles}
    goal = Goal(frozenset(comp_names.values()), frozenset(roles))
    renames = {v: k for k, v in {**comp_names, **conn_names}.items() if k != v}
    return plan_problem(Problem(system, start, goal, replaced=replaced, removed=removed, added=added, renames=renames),
                 strategy, fallback)


def _fresh(name: str, taken: set[str]) -> str:
    candidate, i = name + RENAMED, 2
    while candidate in taken:
        candidate, i = f"{name}{RENAMED}{i}", i + 1
    return candidate


def _same_component(a: Component, b: Component) -> bool:
    """Whether `b` is the running `a`, kept by a migration: the same ports, functionalities,
    command and host. What is declared about it (faults, application, resources, FTM) does not
    change the process, and a host declared on one side only does not move it (an FTM places
    its application on the first of its hosts; without the FTM, the file may not say)."""
    def bare(c: Component) -> Component:
        return dc_replace(c, faults=(), application=(), resources=(), ftm=None, host=None)

    return (a.host == b.host or a.host is None or b.host is None) and bare(a) == bare(b)


def _same_connector(a: Connector, b: Connector) -> bool:
    return (a.kind, a.guarantee, a.single) == (b.kind, b.guarantee, b.single)

