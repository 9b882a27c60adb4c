"""The part of a plan's architecture that the plan can affect, for verifying it in Alloy: the
components the plan names (T), their readers (R), the other publishers those read, as stubs (P);
the lean slice leaves out the readers of stable connectors and all but one witness publisher.
Why verifying the slice verifies the plan: docs/soundness.md#slicing-a-plan-for-alloy.
"""
from __future__ import annotations

from dataclasses import replace as dc_replace
from typing import Callable

from checker.planning.plan import Plan
from checker.semantic_model.actions import Snapshot, catalogue
from checker.semantic_model.config import Configuration
from reconf_dsl import ir

__all__ = ["PlanSlicer", "affected", "slice_plan", "stable_connectors"]


class _Attachments:
    """Who is attached where in some state of the plan, and what the plan acts on: read
    once per plan and shared by the functions below. With `whole` (the attachments of a
    plan this one is a window of), only the connectors whose attachments the window lacks
    are read again."""

    def __init__(self, plan: Plan, whole: _Attachments | None = None, changed: bool = False) -> None:
        # consecutive states share their roles unless a step attaches or detaches
        distinct = {id(s.roles): s.roles for s in plan.states}
        self.roles: set[tuple[str, str, str]] = set().union(*distinct.values())
        self.is_output: Callable[[str, str], bool] = (
            whole.is_output if whole is not None else catalogue(plan.system).is_output)
        # connector -> (component, port, whether an output) of every role, to re-read one
        self.by_conn: dict[str, list[tuple[str, str, bool]]] = {}
        self.pubs: dict[str, set[str]] = {}
        self.reads: dict[str, set[str]] = {}
        if whole is None:
            for conn, comp, port in self.roles:
                out = self.is_output(comp, port)
                self.by_conn.setdefault(conn, []).append((comp, port, out))
                (self.pubs if out else self.reads).setdefault(conn, set()).add(comp)
        else:
            # a window's states are some of the plan's: its roles are a subset of the plan's
            self.by_conn = whole.by_conn
            self.pubs, self.reads = dict(whole.pubs), dict(whole.reads)
            for conn in {r[0] for r in whole.roles - self.roles}:
                pubs = {c for c, port, out in whole.by_conn[conn] if out and (conn, c, port) in self.roles}
                reads = {c for c, port, out in whole.by_conn[conn] if not out and (conn, c, port) in self.roles}
                for table, comps in ((self.pubs, pubs), (self.reads, reads)):
                    if comps:
                        table[conn] = comps
                    else:
                        table.pop(conn, None)
        self.touched = {getattr(a, "component") for a in plan.steps}
        # states given rather than made by the steps (a plan document): whatever changes
        # between two of them is acted on, named by a step or not
        self.changed: set[str] = _changed(plan) if changed else whole.changed if whole is not None else set()
        self.touched |= self.changed


def _changed(plan: Plan) -> set[str]:
    """The components whose presence, modes or attachments differ between consecutive states."""
    out: set[str] = set()
    for a, b in zip(plan.states, plan.states[1:]):
        if a.components is not b.components:
            out |= a.components ^ b.components
        if a.degraded is not b.degraded:
            out |= {c for c, _ in a.degraded ^ b.degraded}
        if a.roles is not b.roles:
            out |= {c for _, c, _ in a.roles ^ b.roles}
    return out


def stable_connectors(plan: Plan, att: _Attachments | None = None) -> set[str]:
    """The connectors T publishes on (in some state) that are satisfied in every state."""
    att = att or _Attachments(plan)
    cat = catalogue(plan.system)
    stable = {conn for conn, ps in att.pubs.items() if ps & att.touched}
    if not stable or not plan.states:
        return stable
    first = Snapshot(cat, plan.states[0])
    stable = {k for k in stable if first.conn_sat(k)}
    # a step changes only its component: only the connectors it publishes on can change
    for step, state in zip(plan.steps, plan.states[1:]):
        comp = getattr(step, "component")
        changed = {k for k in stable if comp in att.pubs[k]}
        if changed:
            st = Snapshot(cat, state)
            stable -= {k for k in changed if not st.conn_sat(k)}
    return stable


def affected(plan: Plan, stable: frozenset[str] = frozenset(), att: _Attachments | None = None) -> set[str]:
    """T ∪ R (see above), with the proxies the plan must keep serving (`Plan.serving`):
    the components whose assumptions the slice judges. Readers of `stable` connectors are
    left out (the lean slice)."""
    att = att or _Attachments(plan)
    core = att.touched | {proxy for _, proxy in plan.serving + plan.handover} | _request_paths(plan, att)
    for conn, ps in att.pubs.items():
        if ps & att.touched and conn not in stable:
            core |= att.reads.get(conn, set())
    return core


def _request_paths(plan: Plan, att: _Attachments) -> set[str]:
    """Every component that a `serving` proxy's requests reach in some state (through the
    readers of what it publishes, its clients' connector aside): the plan module follows
    the path to a protocol, so it keeps them whole."""
    if not plan.serving and not plan.handover:
        return set()
    published: dict[str, set[str]] = {}
    for conn, ps in att.pubs.items():
        for comp in ps:
            published.setdefault(comp, set()).add(conn)
    clients = {conn for conn, _ in plan.serving + plan.handover}
    seen = {proxy for _, proxy in plan.serving + plan.handover}
    frontier = list(seen)
    while frontier:
        comp = frontier.pop()
        for conn in published.get(comp, set()) - clients:
            for reader in att.reads.get(conn, set()) - seen:
                seen.add(reader)
                frontier.append(reader)
    return seen


class PlanSlicer:
    """Slices of windows of one plan (runs of its steps, `Plan` values over some of its
    states), sharing what is read once from the whole plan."""

    def __init__(self, plan: Plan, given: bool = False) -> None:
        """With `given`, the plan's states are given rather than made by its steps (see `_changed`)."""
        self.whole = _Attachments(plan, changed=given)

    def slice(self, window: Plan, lean: bool = False) -> tuple[Plan, set[str]]:
        """`slice_plan(window, lean)` and its core: the components whose assumptions it judges."""
        return _slice(window, lean, _Attachments(window, self.whole))


def slice_plan(plan: Plan, lean: bool = False) -> Plan:
    """The plan on the part of its architecture it can affect (see above)."""
    return _slice(plan, lean, _Attachments(plan))[0]


def _slice(plan: Plan, lean: bool, att: _Attachments) -> tuple[Plan, set[str]]:
    system = plan.system
    pubs, reads = att.pubs, att.reads
    stable = frozenset(stable_connectors(plan, att)) if lean else frozenset()
    core = affected(plan, stable, att)
    stubs: set[str] = set()
    cat = catalogue(system)
    st = Snapshot(cat, plan.states[0]) if lean and plan.states else None
    needed = {conn for conn, rs in reads.items() if rs & core} | stable
    # a `single` topic or a service T publishes on: its other publishers, for its one-publisher rule
    single = {conn for conn, ps in pubs.items() if ps & att.touched and (k := cat.conns.get(conn)) is not None
              and k.single_publisher}
    for conn in sorted(needed | single):
        others = sorted(pubs.get(conn, set()) - core)
        if conn in single:
            others = others[:1] if st is not None else others      # one more is enough to break the rule
        elif st is not None:
            # one witness: the first untouched publisher whose output satisfies the connector
            k = cat.conns.get(conn)
            witnesses = {c for c, p in st.pubs.get(conn, ()) if k is not None and st.output_satisfies(c, p, k.guarantee)}
            others = [c for c in others if c in witnesses][:1]
        stubs |= set(others)
    keep = core | stubs

    def cut(c: ir.Component) -> ir.Component:
        if c.name not in stubs:
            return c
        funcs = tuple(dc_replace(f, normal=dc_replace(f.normal, assumptions=()) if f.normal else None)
                      for f in c.functionalities)
        return dc_replace(c, functionalities=funcs)

    kept = frozenset(r for r in att.roles if r[1] in core or (r[1] in stubs and att.is_output(r[1], r[2])))

    # per distinct roles (see _Attachments), each held so that its id is not reused
    projected: dict[int, tuple[frozenset[tuple[str, str, str]], frozenset[tuple[str, str, str]]]] = {}

    def project(s: Configuration) -> Configuration:
        hit = projected.get(id(s.roles))
        if hit is None or hit[0] is not s.roles:
            hit = projected[id(s.roles)] = (s.roles, s.roles & kept)
        roles = hit[1]
        return Configuration(frozenset(s.components & keep), frozenset(d for d in s.degraded if d[0] in keep), roles)

    states = [project(s) for s in plan.states]
    used = {r[0] for s in states for r in s.roles}
    sliced = dc_replace(system, components=tuple(cut(c) for c in system.components if c.name in keep),
                        versions=tuple(cut(c) for c in system.versions if c.name in keep),
                        connectors=tuple(dc_replace(k, publishers=tuple(r for r in k.publishers if r.component in keep),
                                                    subscribers=tuple(r for r in k.subscribers if r.component in core))
                                         for k in system.connectors if k.name in used))
    goal = dc_replace(plan.goal, components=states[-1].components, roles=states[-1].roles,
                      degraded=states[-1].degraded)
    sliced_plan = Plan(sliced, list(plan.steps), states, plan.strategy, plan.disruption, goal, dict(plan.renames),
                       list(plan.notes), plan.verification, list(plan.serving), sorted(stable),
                       [(x, p) for x, p in plan.protocols if p in keep], list(plan.handover))
    return sliced_plan, core
