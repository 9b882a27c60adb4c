"""The `paper` strategy: Algorithm 1 of paper 001 (§4.4), break before make.

For each component c leaving (replaced or removed): detach every port of c, in declaration
order, degrading the affected functionalities before each detach; remove c. Then for each
component c' arriving: create c' degraded, attach its inputs, upgrade its functionalities,
attach its outputs. Rewired attachments of the remaining components are detached the same
way (degrade first) before the arrivals and attached after them. Finally the degraded
functionalities of the other components are upgraded (until none can be), except those
the target keeps degraded (residual degradation, `plan.settle`).

The paper's recursive Degrade would not terminate on a cyclic dependency; a visited set
guards it here: docs/soundness.md#the-papers-algorithm-1.
"""
from __future__ import annotations

from checker.planning.plan import NoSafePlan, Problem
from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Snapshot,
    Upgrade,
    affected_connectors,
    catalogue,
    check,
    effect,
)
from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.ir import System

__all__ = ["paper_steps"]


class _Run:
    def __init__(self, system: System, start: Configuration) -> None:
        self.system = system
        self.cat = catalogue(system)
        self.config = start
        self.steps: list[Action] = []
        self.visited: set[FuncId] = set()

    def snap(self) -> Snapshot:
        return Snapshot(self.cat, self.config)

    def do(self, action: Action) -> None:
        reasons = check(self.snap(), action)
        if reasons:
            raise NoSafePlan([f"paper: cannot {action.describe()}: " + "; ".join(reasons)])
        self.steps.append(action)
        self.config = effect(self.system, self.config, action)

    # AffectedFuncs(c, inputs): functionalities of c with an assumption no remaining input provides.
    def affected_funcs(self, comp: str, dead: frozenset[str] = frozenset(),
                       dead_role: tuple[str, str, str] | None = None) -> list[str]:
        return sorted({f for _, f, _ in self.snap().unsafe([comp], dead, dead_role)})

    def degrade_by_conn(self, conns: list[str]) -> None:
        st = self.snap()
        readers = sorted({c for conn in conns for c, p in st.by_conn.get(conn, []) if not st.is_output(c, p)})
        for c in readers:
            for f in self.affected_funcs(c, frozenset(conns)):
                self.degrade(c, f)

    def degrade(self, comp: str, func: str) -> None:
        if (comp, func) in self.visited or (comp, func) in self.config.degraded:
            return
        self.visited.add((comp, func))
        self.degrade_by_conn(affected_connectors(self.snap(), comp, self.cat.funcs[(comp, func)]))
        self.do(Degrade(comp, func))

    def detach(self, conn: str, comp: str, port: str) -> None:
        st = self.snap()
        if st.is_output(comp, port):
            if not st.conn_sat(conn, [(comp, port)]):
                self.degrade_by_conn([conn])
        else:
            for f in self.affected_funcs(comp, dead_role=(conn, comp, port)):
                self.degrade(comp, f)
        self.do(Detach(conn, comp, port))

    def upgrade_all(self, comps: list[str], keep: frozenset[FuncId]) -> None:
        progress = True
        while progress:
            progress = False
            for c, f in sorted(self.config.degraded - keep):
                if c in comps and not check(self.snap(), Upgrade(c, f)):
                    self.do(Upgrade(c, f))
                    progress = True


def paper_steps(p: Problem) -> list[Action]:
    run = _Run(p.system, p.start)
    leaving = [old for old, _ in p.replaced] + list(p.removed)
    for c in leaving:
        for decl in run.cat.comps[c].ports:
            for conn in run.config.connector_of(c, decl.name):
                run.detach(conn, c, decl.name)
        run.do(Remove(c))
    for conn, c, port in sorted(run.config.roles - p.goal.roles):
        if (conn, c, port) in run.config.roles:
            run.detach(conn, c, port)
    for c in [new for _, new in p.replaced] + list(p.added):
        comp = run.cat.comps[c]
        run.do(Create(c))
        goal_ports = sorted((conn, port) for conn, comp_, port in p.goal.roles if comp_ == c)
        for conn, port in goal_ports:
            if not run.snap().is_output(c, port):
                run.do(Attach(conn, c, port))
        for f in comp.functionalities:
            if (c, f.name) not in p.goal.degraded and not check(run.snap(), Upgrade(c, f.name)):
                run.do(Upgrade(c, f.name))
        for conn, port in goal_ports:
            if (conn, c, port) not in run.config.roles:
                run.do(Attach(conn, c, port))
    rest = sorted(p.goal.roles - run.config.roles, key=lambda r: (run.snap().is_output(r[1], r[2]), r))
    for conn, c, port in rest:
        run.do(Attach(conn, c, port))
    run.upgrade_all(sorted(run.config.components), p.goal.degraded)
    # What the target keeps degraded and no detach degraded on the way (not in Algorithm 1).
    for c, name in sorted(p.goal.degraded - run.config.degraded):
        if c in run.config.components:
            run.degrade(c, name)
    return run.steps
