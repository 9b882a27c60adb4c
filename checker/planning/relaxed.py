"""A necessary condition for a plan to exist, checked in polynomial time: the relaxation in
which nothing is ever lost (`reachable`). A fact of the target it never gathers proves that no
plan exists, and says why. Why each precondition's generous reading (`_Relaxed`) makes it
necessary: docs/soundness.md#the-relaxation.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Optional

from checker.planning.plan import Goal
from checker.semantic_model.actions import catalogue, satisfies
from checker.semantic_model.config import Configuration, FuncId, Role
from reconf_dsl.ir import Functionality, Predicate, System

__all__ = ["Relaxation", "reachable"]


@dataclass
class Relaxation:
    """What the relaxation gathered, and which facts of the target it never did (in words)."""

    present: set[str]
    absent: set[str]
    attached: set[Role]
    detached: set[Role]
    normal: set[FuncId]
    degraded: set[FuncId]
    missing: list[str]

    @property
    def possible(self) -> bool:
        return not self.missing


class _Relaxed:
    def __init__(self, system: System, start: Configuration, goal: Goal, relevant: Optional[frozenset[FuncId]],
                 restricted: bool) -> None:
        cat = self.cat = catalogue(system)
        self.comps = sorted(start.components | goal.components)
        self.roles = sorted(r for r in start.roles | goal.roles
                            if r[1] in cat.comps and r[0] in cat.conns and (r[1], r[2]) in cat.ports)
        self.present = set(start.components)
        self.absent = set(self.comps) - start.components
        self.attached = set(start.roles)
        self.detached = set(self.roles) - start.roles
        funcs = [(c, f.name) for c in start.components for f in cat.comps[c].functionalities]
        self.degraded = {d for d in funcs if d in start.degraded}
        self.normal = {d for d in funcs if d not in start.degraded}
        self.pubs: dict[str, list[Role]] = {}
        self.subs: dict[str, list[Role]] = {}
        self.of_port: dict[tuple[str, str], list[Role]] = {}
        self.of_comp: dict[str, list[Role]] = {}
        for r in self.roles:
            (self.pubs if cat.is_output(r[1], r[2]) else self.subs).setdefault(r[0], []).append(r)
            self.of_port.setdefault((r[1], r[2]), []).append(r)
            self.of_comp.setdefault(r[1], []).append(r)
        self.env = cat.env
        if restricted:
            wanted, unwanted = goal.roles - start.roles, start.roles - goal.roles
            self.attachable = [r for r in self.roles if r in wanted]
            self.detachable = [r for r in self.roles if r in unwanted]
            self.creatable = sorted(goal.components - start.components)
            self.removable = sorted(start.components - goal.components)
        else:
            self.attachable = self.detachable = self.roles
            self.creatable = self.removable = self.comps
        self.changing = relevant if restricted else None

    # -- what may hold -----------------------------------------------------------------------

    def _guarantee_satisfies(self, c: str, port: str, want: Predicate) -> bool:
        """Some functionality of `c` on output `port` may be in a mode whose guarantee satisfies `want`."""
        for f in self.cat.comps[c].functionalities:
            if port not in f.ports:
                continue
            d = (c, f.name)
            if f.normal is not None and d in self.normal and satisfies(f.normal.guarantee(port), want):
                return True
            if f.degraded is not None and d in self.degraded and satisfies(f.degraded.guarantee(port), want):
                return True
        return False

    def conn_sat(self, conn: str, without: frozenset[tuple[str, str]] = frozenset()) -> bool:
        want = self.cat.conns[conn].guarantee
        return any(r in self.attached and r[1] in self.present and (r[1], r[2]) not in without
                   and self._guarantee_satisfies(r[1], r[2], want) for r in self.pubs.get(conn, ()))

    def holds(self, c: str, f: Functionality, a: Predicate, dead: Optional[str] = None,
              dead_role: Optional[Role] = None) -> bool:
        if any(satisfies(e, a) for e in self.env):
            return True
        for pname in f.ports:
            p = self.cat.ports.get((c, pname))
            if p is None or p.kind != "input" or p.assumption is None or not satisfies(p.assumption, a):
                continue
            for r in self.of_port.get((c, pname), ()):
                if (r in self.attached and r[0] != dead and r != dead_role and self.conn_sat(r[0])
                        and satisfies(self.cat.conns[r[0]].guarantee, p.assumption)):
                    return True
        return False

    def safe(self, c: str, dead: Optional[str] = None, dead_role: Optional[Role] = None,
             exempt: Optional[FuncId] = None) -> bool:
        """Every functionality of `c` may be safe without `dead` (or `dead_role`)."""
        for f in self.cat.comps[c].functionalities:
            d = (c, f.name)
            if d == exempt or d in self.degraded:
                continue
            if f.normal is None or not all(self.holds(c, f, a, dead, dead_role) for a in f.normal.assumptions):
                return False
        return True

    def readers_safe(self, conn: str, exempt: Optional[FuncId] = None) -> bool:
        """Every component that may read `conn` may be absent, detached from it, or safe without it."""
        return all(r in self.detached or r[1] in self.absent or self.safe(r[1], dead=conn, exempt=exempt)
                   for r in self.subs.get(conn, ()) if r in self.attached and r[1] in self.present)

    # -- the actions ---------------------------------------------------------------------------

    def may_degrade(self, d: FuncId) -> bool:
        c, name = d
        f = self.cat.funcs[d]
        if c not in self.present or d not in self.normal or f.degraded is None:
            return False
        outs = [p for p in f.ports if self.cat.is_output(c, p)]
        mine = frozenset((c, p) for p in outs)
        for conn in sorted({r[0] for p in outs for r in self.of_port.get((c, p), ()) if r in self.attached}):
            on = [r for r in self.pubs.get(conn, ()) if r[1] == c and r[2] in outs]
            if all(r in self.detached for r in on) or self.conn_sat(conn, mine):
                continue
            want = self.cat.conns[conn].guarantee
            if any(r in self.attached and satisfies(f.degraded.guarantee(r[2]), want) for r in on):
                continue
            if not self.readers_safe(conn, exempt=d):
                return False
        return True

    def may_upgrade(self, d: FuncId) -> bool:
        c, _ = d
        f = self.cat.funcs[d]
        return (c in self.present and d in self.degraded and f.normal is not None
                and all(self.holds(c, f, a) for a in f.normal.assumptions))

    def may_detach(self, r: Role) -> bool:
        conn, c, p = r
        if r not in self.attached or c not in self.present:
            return False
        if not self.cat.is_output(c, p):
            return self.safe(c, dead_role=r)
        return self.conn_sat(conn, frozenset([(c, p)])) or self.readers_safe(conn)

    def may_attach(self, r: Role) -> bool:
        conn, c, p = r
        if c not in self.present:
            return False
        want = self.cat.conns[conn].guarantee
        if self.cat.is_output(c, p):
            return self._guarantee_satisfies(c, p, want)
        port = self.cat.ports[(c, p)]
        return port.assumption is not None and satisfies(want, port.assumption)

    def run(self, deadline: Optional[float] = None) -> bool:
        """Add facts until none is added; False if `deadline` (time.perf_counter) came first."""
        cat = self.cat
        changed = True
        while changed:
            if deadline is not None and time.perf_counter() > deadline:
                return False
            changed = False
            for c in self.creatable:
                if c in self.absent and c not in self.present and all(f.degraded is not None
                                                                      for f in cat.comps[c].functionalities):
                    self.present.add(c)
                    self.degraded |= {(c, f.name) for f in cat.comps[c].functionalities}
                    changed = True
            for c in self.removable:
                if c in self.present and c not in self.absent and all(r in self.detached
                                                                      for r in self.of_comp.get(c, ())):
                    self.absent.add(c)
                    changed = True
            for r in self.attachable:
                if r not in self.attached and self.may_attach(r):
                    self.attached.add(r)
                    changed = True
            for r in self.detachable:
                if r not in self.detached and self.may_detach(r):
                    self.detached.add(r)
                    changed = True
            for c in sorted(self.present):
                for f in cat.comps[c].functionalities:
                    d = (c, f.name)
                    if self.changing is not None and d not in self.changing:
                        continue
                    if d not in self.degraded and self.may_degrade(d):
                        self.degraded.add(d)
                        changed = True
                    if d not in self.normal and self.may_upgrade(d):
                        self.normal.add(d)
                        changed = True
        return True


def reachable(system: System, start: Configuration, goal: Goal, restricted: bool = False,
              relevant: Optional[frozenset[FuncId]] = None, deadline: Optional[float] = None) -> Relaxation:
    """The relaxation of the planning problem (see the module docstring) and the facts of
    `goal` it never gathers, each in words; none when `deadline` (time.perf_counter) passed
    before the relaxation was complete (it then proves nothing)."""
    r = _Relaxed(system, start, goal, relevant, restricted)
    missing: list[str] = []
    if not r.run(deadline):
        return Relaxation(r.present, r.absent, r.attached, r.detached, r.normal, r.degraded, missing)
    for c in r.comps:
        if c in goal.components and c not in r.present:
            missing.append(f"{c} can never be created")
        elif c not in goal.components and c not in r.absent:
            left = [x for x in r.of_comp.get(c, ()) if x not in r.detached]
            missing.append(f"{c} can never be removed" + (f": {_role(left[0])} can never be detached" if left else ""))
    for x in r.roles:
        if x in goal.roles and x not in r.attached:
            missing.append(f"{_role(x)} can never be attached")
        elif x not in goal.roles and x not in r.detached and x[1] in goal.components:
            missing.append(f"{_role(x)} can never be detached")
    for c in sorted(goal.components):
        for f in r.cat.comps[c].functionalities:
            d = (c, f.name)
            if d in goal.degraded and d not in r.degraded:
                missing.append(f"{c}.{f.name} can never be degraded")
            elif d not in goal.degraded and d not in r.normal:
                missing.append(f"{c}.{f.name} can never be normal")
    return Relaxation(r.present, r.absent, r.attached, r.detached, r.normal, r.degraded, missing)


def _role(r: Role) -> str:
    return f"{r[1]}.{r[2]} → {r[0]}"
