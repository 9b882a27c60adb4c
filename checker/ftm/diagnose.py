"""`reconf check`'s FTM diagnostics (RC4xx): an attached FTM that contradicts its component's
(F, A, R), at the span of the mechanism that assumes what does not hold.

RC401 ill-formed composition · RC402 a declared fault is not tolerated · RC403 an
application characteristic is missing (LFR on a non-deterministic server, PBR without state
access) · RC404 too little bandwidth (PBR on low bandwidth) · RC405 too few CPUs · RC406 a
duplex without two hosts (warning) · RC407 nothing to protect.
"""
from __future__ import annotations

from typing import Iterable, Optional

from checker.ftm.expand import protected_connector
from checker.ftm.library import compose
from checker.ftm.select import judge, profile
from reconf_dsl import ir
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Related, error, warning

__all__ = ["ftm_diagnostics", "ftm_findings", "in_order"]


def _span_of(expr: ir.FtmExpr, mechanism: str) -> ir.Span:
    e: Optional[ir.FtmExpr] = expr
    while e is not None:
        if e.name == mechanism:
            return e.span
        e = e.inner
    return expr.span


def ftm_diagnostics(system: ir.System, only: Optional[set[str]] = None) -> list[Diagnostic]:
    """RC401–RC407 for every component with an FTM (or only those named in `only`)."""
    return in_order(d for _, d in ftm_findings(system, only))


def in_order(diags: Iterable[Diagnostic]) -> list[Diagnostic]:
    """Diagnostics by position, then code."""
    return sorted(diags, key=lambda d: (d.span.file, d.span.line, d.span.col, d.code))


def ftm_findings(system: ir.System, only: Optional[set[str]] = None) -> list[tuple[str, Diagnostic]]:
    """Each FTM diagnostic with the component it is about."""
    out: list[tuple[str, Diagnostic]] = []
    for c in system.components:
        if c.ftm is None or (only is not None and c.name not in only):
            continue
        out += [(c.name, d) for d in _component_findings(system, c)]
    return out


def _component_findings(system: ir.System, c: ir.Component) -> list[Diagnostic]:
    assert c.ftm is not None
    out: list[Diagnostic] = []
    expr = c.ftm.expr
    comp, problems = compose(expr)
    if comp is None:
        return [error("RC401", f"ill-formed FTM '{expr}' on '{c.name}': {p}", expr.span) for p in problems]
    prof = profile(system, c)
    for r in judge(comp, prof):
        span = expr.span if not r.mechanism else _span_of(expr, r.mechanism)
        related: tuple[Related, ...] = ()
        if r.code == "RC404" and prof.bandwidth_span is not None:
            related = (Related(prof.bandwidth_span, "bandwidth set here"),)
        if r.code == "RC405" and prof.cpus_span is not None:
            related = (Related(prof.cpus_span, "CPUs set here"),)
        notes = (f"`reconf ftm select {c.name}` lists the mechanisms valid here",)
        out.append(error(r.code, f"{r.text} ('{c.name}')", span, related=related, notes=notes))
    if comp.duplex is not None and len(set(c.ftm.hosts)) < 2:
        given = "1 distinct host is given" if set(c.ftm.hosts) else "no distinct hosts are given"
        out.append(warning("RC406", f"{comp.duplex.name} replicates '{c.name}' on two hosts, but {given}",
                           c.ftm.span,
                           notes=(f"write `ftm {expr} on host_a, host_b`",)))
    try:
        protected_connector(system, c)
    except DiagnosticError as e:
        out += e.diagnostics
    return out
