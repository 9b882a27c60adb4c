"""The semantics the executor replays and judges by: satisfaction, the safety property and the
six actions' structural preconditions and effects, over a plan document's model.

This is the executor's own copy, standard library only (plan scripts embed it), of what
`checker.semantic_model` defines; tests/test_executor.py holds the two to the same verdicts (docs/soundness.md)."""
from __future__ import annotations

from fractions import Fraction
from typing import Iterable, Optional

from .plan_states import State
from .steps import ComponentDoc, ConnectorDoc, FunctionalityDoc, ModeDoc, ModelDoc, PortDoc, PredicateDoc, Step


def rate(p: Optional[PredicateDoc]) -> Optional[Fraction]:
    return None if p is None or p.get("hz") is None else Fraction(str(p["hz"]))


def satisfies(p: Optional[PredicateDoc], q: Optional[PredicateDoc]) -> bool:
    """p satisfies q iff both are data of the same type and (q has no rate, or p has a rate >= q's)."""
    if p is None or q is None or p["message"] is None or q["message"] is None or p["message"] != q["message"]:
        return False
    q_hz = rate(q)
    if q_hz is None:
        return True
    p_hz = rate(p)
    return p_hz is not None and p_hz >= q_hz


class Model:
    """A plan document's model: components, connectors, environment."""

    def __init__(self, model: ModelDoc) -> None:
        self.comps: dict[str, ComponentDoc] = {c["name"]: c for c in model["components"]}
        self.conns: dict[str, ConnectorDoc] = {c["name"]: c for c in model["connectors"]}
        self.env: list[PredicateDoc] = [e["guarantee"] for e in model["environment"]]

    def port(self, comp: str, name: str) -> Optional[PortDoc]:
        for p in self.comps[comp]["ports"]:
            if p["name"] == name:
                return p
        return None

    def port_kind(self, comp: str, name: str) -> str:
        """"input", "output", or "" for a port the model does not declare."""
        p = self.port(comp, name) if comp in self.comps else None
        return "" if p is None else p["kind"]

    def mode(self, comp: str, f: FunctionalityDoc, state: State) -> ModeDoc:
        return f["degraded"] if (comp, f["name"]) in state.degraded else f["normal"]

    @staticmethod
    def guarantee(mode: ModeDoc, port: str) -> Optional[PredicateDoc]:
        for g in mode["guarantees"]:
            if g["port"] == port:
                return g["predicate"]
        return None

    def satisfying(self, state: State, conn: str) -> list[str]:
        """The present components whose outputs satisfy `conn` in `state`."""
        want = self.conns[conn]["guarantee"]
        out = []
        for n, comp, pname in sorted(state.roles):
            if n != conn or comp not in state.components or comp not in self.comps:
                continue
            if self.port_kind(comp, pname) != "output":
                continue
            if any(pname in f["ports"] and satisfies(self.guarantee(self.mode(comp, f, state), pname), want)
                   for f in self.comps[comp]["functionalities"]):
                out.append(comp)
        return out

    def failures(self, state: State) -> list[str]:
        """Every assumption of a present functionality's current mode that does not hold, in words."""
        return [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in self.failing(state)]

    def failing(self, state: State) -> list[tuple[str, str, str]]:
        """(component, functionality, assumption's text) of every assumption of a present
        functionality's current mode that does not hold."""
        present = [c for c in sorted(state.components) if c in self.comps]
        feeds: dict[tuple[str, str], list[str]] = {}
        for conn, comp, pname in sorted(state.roles):
            if comp in present and conn in self.conns and self.port_kind(comp, pname) == "input":
                feeds.setdefault((comp, pname), []).append(conn)
        conn_sat = {name: bool(self.satisfying(state, name)) for name in self.conns}

        def input_sat(comp: str, p: PortDoc) -> bool:
            return any(conn_sat[cn] and satisfies(self.conns[cn]["guarantee"], p["assumption"])
                       for cn in feeds.get((comp, p["name"]), []))

        def holds(comp: str, f: FunctionalityDoc, a: PredicateDoc) -> bool:
            for pname in f["ports"]:
                p = self.port(comp, pname)
                if p is not None and p["kind"] == "input" and input_sat(comp, p) and satisfies(p["assumption"], a):
                    return True
            return any(satisfies(e, a) for e in self.env)

        out: list[tuple[str, str, str]] = []
        for comp in present:
            for f in self.comps[comp]["functionalities"]:
                for a in self.mode(comp, f, state)["assumptions"]:
                    if not holds(comp, f, a):
                        out.append((comp, f["name"], a["text"]))
        return out

    def relying_inputs(self, comp: str, state: State) -> list[str]:
        """Inputs of `comp` that a functionality in its normal mode (in `state`) relies on."""
        return sorted({p for f in self.comps[comp]["functionalities"] if (comp, f["name"]) not in state.degraded
                       for p, _ in self.relied_on(comp, f)})

    def relied_on(self, comp: str, f: FunctionalityDoc) -> list[tuple[str, PredicateDoc]]:
        """The inputs of `comp` that functionality `f`'s normal assumptions rely on, each with the
        assumption it meets."""
        out = []
        for a in f["normal"]["assumptions"]:
            for pname in f["ports"]:
                p = self.port(comp, pname)
                if p is not None and p["kind"] == "input" and satisfies(p["assumption"], a):
                    out.append((pname, a))
        return out

    def refusal(self, state: State, step: Step) -> Optional[str]:
        """Why `step` cannot run in `state` at all (the structural part of its preconditions)."""
        comp = step.component
        if step.action == "create":
            if comp not in self.comps:
                return f"no component {comp} is declared"
            return f"{comp} is already in the system" if comp in state.components else None
        if comp not in state.components:
            return f"{comp} is not in the system"
        if step.action == "remove":
            attached = [f"{comp}.{p} is attached to {n}" for n, c, p in sorted(state.roles) if c == comp]
            return f"{comp} is not isolated: " + "; ".join(attached) if attached else None
        if step.action in ("attach", "detach"):
            return self._port_refusal(state, step)
        names = [f["name"] for f in self.comps[comp]["functionalities"]]
        fid = (comp, step.functionality)
        if step.functionality not in names:
            return f"{comp} has no functionality {step.functionality}"
        if step.action == "degrade" and fid in state.degraded:
            return f"{comp}.{step.functionality} is already degraded"
        if step.action == "upgrade" and fid not in state.degraded:
            return f"{comp}.{step.functionality} is not degraded"
        return None

    def _port_refusal(self, state: State, step: Step) -> Optional[str]:
        where = f"{step.component}.{step.port}"
        if step.connector not in self.conns or self.port(step.component, step.port) is None:
            return f"{where} or {step.connector} is not declared"
        if step.action == "attach" and step.role in state.roles:
            return f"{where} is already attached to {step.connector}"
        if step.action == "detach" and step.role not in state.roles:
            return f"{where} is not attached to {step.connector}"
        return None

    def effect(self, state: State, step: Step) -> State:
        comp = step.component
        if step.action == "remove":
            return State(state.components - {comp}, [d for d in state.degraded if d[0] != comp], state.roles)
        if step.action == "create":
            funcs = [(comp, f["name"]) for f in self.comps[comp]["functionalities"]]
            return State(state.components | {comp}, state.degraded | set(funcs), state.roles)
        if step.action in ("attach", "detach"):
            roles = state.roles | {step.role} if step.action == "attach" else state.roles - {step.role}
            return State(state.components, state.degraded, roles)
        fid = (comp, step.functionality)
        degraded = state.degraded | {fid} if step.action == "degrade" else state.degraded - {fid}
        return State(state.components, degraded, state.roles)

    def differences(self, expected: State, observed: State, comps: Iterable[str]) -> list[str]:
        """What differs between two configurations, for the components `comps`, in words."""
        out = []
        for c in sorted(comps):
            if (c in expected.components) != (c in observed.components):
                out.append(f"{c} is {'running' if c in observed.components else 'not running'}, "
                           f"the plan expects it {'present' if c in expected.components else 'absent'}")
                continue
            if c not in observed.components:
                continue
            for f in self.comps[c]["functionalities"]:
                e, o = (c, f["name"]) in expected.degraded, (c, f["name"]) in observed.degraded
                if e != o:
                    out.append(f"{c}.{f['name']} is {'degraded' if o else 'normal'}, "
                               f"the plan expects {'degraded' if e else 'normal'}")
            for p in self.comps[c]["ports"]:
                e2 = sorted(n for n, cc, pp in expected.roles if cc == c and pp == p["name"])
                o2 = sorted(n for n, cc, pp in observed.roles if cc == c and pp == p["name"])
                if e2 != o2:
                    out.append(f"{c}.{p['name']} is attached to {o2 or 'nothing'}, the plan expects {e2 or 'nothing'}")
        return out
