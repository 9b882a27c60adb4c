"""Selection (docs/ftm.md#selection): from a component's (F, A, R), every FTM and composition that
is valid, ranked by resource cost, and for each other one the assumptions that rule it out.

(F, A, R) of a component: F its `faults`; A its `application` characteristics (a
characteristic not declared is not assumed: an application is deterministic, or has state
access, only when it says so); R its `resources`, else what the hosts of its `ftm ... on`
clause offer (the lowest bandwidth among them, the sum of their CPUs). A resource said
nowhere is not a constraint.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from checker.ftm.library import BANDWIDTH, Composition, all_compositions, bandwidth_rank
from reconf_dsl import ir

__all__ = ["Profile", "profile", "Reason", "Candidate", "judge", "select"]


@dataclass(frozen=True)
class Profile:
    """The (F, A, R) of a component; None = not constrained."""

    faults: frozenset[str]
    application: frozenset[str]
    bandwidth: Optional[str]
    cpus: Optional[int]
    bandwidth_span: Optional[ir.Span] = None
    cpus_span: Optional[ir.Span] = None


def _setting(settings: tuple[ir.ResourceSetting, ...], name: str) -> Optional[ir.ResourceSetting]:
    return next((r for r in settings if r.name == name), None)


def profile(system: ir.System, comp: ir.Component, hosts: Optional[tuple[str, ...]] = None) -> Profile:
    hosts = hosts if hosts is not None else (comp.ftm.hosts if comp.ftm is not None else ())
    declared = [h for h in system.hosts if h.name in set(hosts)]
    bw = _setting(comp.resources, "bandwidth")
    bandwidth: Optional[str] = bw.value if bw else None
    bw_span = bw.span if bw else None
    if bw is None and declared:
        found = [_setting(h.resources, "bandwidth") for h in declared]
        if all(found):
            low = min(found, key=lambda r: bandwidth_rank(r.value))  # type: ignore[union-attr]
            assert low is not None
            bandwidth, bw_span = low.value, low.span
    cp = _setting(comp.resources, "cpus")
    cpus: Optional[int] = int(cp.value) if cp else None
    cpus_span = cp.span if cp else None
    if cp is None and declared:
        found = [_setting(h.resources, "cpus") for h in declared]
        if all(found):
            cpus = sum(int(r.value) for r in found if r is not None)
            cpus_span = found[0].span if found[0] is not None else None
    return Profile(frozenset(comp.faults), frozenset(comp.application), bandwidth, cpus, bw_span, cpus_span)


@dataclass(frozen=True)
class Reason:
    """One assumption of a composition that the profile contradicts."""

    code: str        # RC402 fault not covered, RC403 application, RC404 bandwidth, RC405 CPUs
    mechanism: str   # the mechanism whose assumption fails ("" for coverage)
    text: str


def judge(comp: Composition, prof: Profile) -> list[Reason]:
    """Every reason `comp` is not valid for `prof` (empty: valid)."""
    out: list[Reason] = []
    missing = sorted(prof.faults - comp.covers)
    if missing:
        out.append(Reason("RC402", "", f"{comp} does not tolerate {', '.join(missing)} faults"))
    for m in comp.mechanisms:
        for need in sorted(m.needs):
            if need not in prof.application:
                word = {"deterministic": "a deterministic application",
                        "state_access": "state access (get/set state)"}.get(need, need)
                said = _application_said(prof, need)
                out.append(Reason("RC403", m.name, f"{m.name} needs {word}, and the application {said}"))
        if prof.bandwidth is not None and bandwidth_rank(prof.bandwidth) < bandwidth_rank(m.bandwidth):
            out.append(Reason("RC404", m.name, f"{m.name} needs {m.bandwidth} bandwidth, only {prof.bandwidth} "
                                               "is available"))
        if prof.cpus is not None and prof.cpus < m.cpus:
            out.append(Reason("RC405", m.name, f"{m.name} needs {m.cpus} CPUs, only {prof.cpus} available"))
    return out


def _application_said(prof: Profile, need: str) -> str:
    negative = {"deterministic": "non_deterministic", "state_access": "no_state_access"}[need] \
        if need in ("deterministic", "state_access") else ""
    if negative and negative in prof.application:
        return f"is declared {negative}"
    return f"does not declare `{need}`"


@dataclass(frozen=True)
class Candidate:
    composition: Composition
    reasons: tuple[Reason, ...]

    @property
    def valid(self) -> bool:
        return not self.reasons

    @property
    def cost(self) -> tuple[int, int, int, int, int]:
        """CPUs, then bandwidth, then nodes of the expanded graph, then mechanisms, then faults
        covered (the least mechanism that does the job first)."""
        c = self.composition
        return (c.cpus, bandwidth_rank(c.bandwidth), nodes(c), len(c.names), len(c.covers))

    def to_dict(self) -> dict[str, object]:
        c = self.composition
        return {"ftm": str(c), "valid": self.valid, "covers": sorted(c.covers), "cpus": c.cpus,
                "bandwidth": c.bandwidth, "nodes": nodes(c),
                "reasons": [{"code": r.code, "mechanism": r.mechanism, "text": r.text} for r in self.reasons]}


def nodes(c: Composition) -> int:
    """Components of the expanded graph: proxy; per replica the application, a Protocol, Before
    and After per layer and one Proceed; crash detectors and Recovery; SEC's client side and CA."""
    n = 1 + c.replicas * (2 + 3 * len(c.names))
    if c.duplex:
        n += 3
    if "SEC" in c.names:
        n += 3
    return n


def select(prof: Profile) -> list[Candidate]:
    """Every composition judged: the valid ones first, cheapest first; then the others."""
    cands = [Candidate(c, tuple(judge(c, prof))) for c in all_compositions()]
    return sorted(cands, key=lambda k: (not k.valid, k.cost, str(k.composition)))


assert BANDWIDTH[0] == "nil"
