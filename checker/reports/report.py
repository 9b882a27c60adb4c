"""Renderers: diagnostics and check results as text (caret snippets) or JSON.

Stages never print; the CLI hands their data to one of these."""
from __future__ import annotations

import enum
import json
import os
from typing import Any, Optional, TextIO

from checker.reports.formats import CheckCase
from checker.semantic_model.semantics import AssumptionResult, Evaluation
from reconf_dsl.diagnostics import Diagnostic, Related, Severity, error
from reconf_dsl.loader import Sources
from reconf_dsl.span import Span

FORMAT_VERSION = 1


class OutputFormat(str, enum.Enum):
    """Formats of every command (plans, failures)."""
    TEXT = "text"
    JSON = "json"


class ReportFormat(str, enum.Enum):
    """Formats of commands that report findings (`check`, `gate`): also for code scanning and CI."""
    TEXT = "text"
    JSON = "json"
    SARIF = "sarif"
    GITHUB = "github"
    JUNIT = "junit"


_DEPTH = {"functionality": 0, "assumption": 0, "input": 1, "environment": 1, "connector": 2, "output": 3}


def assumption_diagnostic(r: AssumptionResult) -> Diagnostic:
    """An unsatisfied assumption, with its explanation chain as related spans."""
    related = tuple(Related(link.span, link.text, _DEPTH.get(link.kind, 1)) for link in r.chain
                    if link.kind not in ("functionality", "assumption"))
    return error("RC201", f"{r.component}.{r.functionality} assumes {r.assumption}, which does not hold",
                 r.assumption.span, related=related)


def explanation(r: AssumptionResult, indent: str = "  ") -> str:
    """An assumption's chain, a line a link, each indented by its depth and marked ✓ or ✗."""
    return "\n".join((indent * _DEPTH.get(ln.kind, 1)) + ("✓ " if ln.ok else "✗ ") + f"{ln.text}  ({ln.span})"
                     for ln in r.chain)


def assumption_cases(system: str, ev: Evaluation) -> list[CheckCase]:
    """One JUnit case per checked assumption; a failing one carries its explanation chain."""
    cases = []
    for r in ev.results:
        details = explanation(r)
        cases.append(CheckCase(f"{system}.{r.component}.{r.functionality}",
                               f"assumption {r.index + 1}: {r.assumption}",
                               None if r.holds else f"{r.component}.{r.functionality} assumes {r.assumption}, "
                               "which does not hold", details, r.assumption.span))
    return cases


def snippet(sources: Sources, span: Span, gutter: int) -> list[str]:
    line = sources.line(span.file, span.line)
    if line is None:
        return []
    shown = line.expandtabs(4).rstrip()
    start = len(line[: span.col - 1].expandtabs(4))
    if span.end_line == span.line and span.end_col > span.col:
        width = len(line[span.col - 1: span.end_col - 1].expandtabs(4))
    else:
        width = max(1, len(shown) - start)
    if len(shown) > SNIPPET_WIDTH:          # a long line: the part around the caret, not all of it
        lo = max(0, min(start - SNIPPET_WIDTH // 4, len(shown) - SNIPPET_WIDTH))
        hi = lo + SNIPPET_WIDTH
        before, after = ("…" if lo > 0 else ""), ("…" if hi < len(shown) else "")
        shown = before + shown[lo:hi] + after
        start, width = start - lo + len(before), max(1, min(width, hi - start))
    pad = " " * gutter
    return [f"{span.line:>{gutter}} | {shown}", f"{pad} | {' ' * start}{'^' * max(1, width)}"]


SNIPPET_WIDTH = 160
"""Characters of a source line a snippet shows at most (a minified or hostile file has lines of megabytes)."""


def render_text(diags: list[Diagnostic], sources: Sources, out: TextIO) -> None:
    for d in diags:
        gutter = max(len(str(d.span.line)), 2)
        # a pseudo-file ("<alloy>") has no position, but standard input ("<stdin>") was read and has
        where = "reconf" if d.span.file.startswith("<") and d.span.file not in sources.texts else str(d.span)
        out.write(f"{where}: {d.severity.value}[{d.code}]: {d.message}\n")
        for line in snippet(sources, d.span, gutter):
            out.write(line + "\n")
        for r in d.related:
            lead = " " * gutter + "   " + "   " * max(0, r.depth - 1)
            out.write(f"{lead}{'└─ ' if r.depth else '= '}{r.message}  ({r.span})\n")
        for n in d.notes:
            out.write(f"{' ' * gutter} = note: {n}\n")


def span_json(span: Span) -> dict[str, Any]:
    return {"file": span.file, "line": span.line, "column": span.col, "end_line": span.end_line,
            "end_column": span.end_col}


def diagnostic_json(d: Diagnostic) -> dict[str, Any]:
    return {"code": d.code, "severity": d.severity.value, "message": d.message, "span": span_json(d.span),
            "related": [{"message": r.message, "span": span_json(r.span), "depth": r.depth} for r in d.related],
            "notes": list(d.notes)}


def evaluation_json(ev: Evaluation) -> list[dict[str, Any]]:
    return [{"component": r.component, "functionality": r.functionality, "index": r.index,
             "assumption": str(r.assumption), "holds": r.holds, "span": span_json(r.assumption.span),
             "chain": [{"kind": ln.kind, "text": ln.text, "span": span_json(ln.span)} for ln in r.chain]}
            for r in ev.results]


def document(command: str, verdict: str, diags: list[Diagnostic], **extra: Any) -> str:
    doc: dict[str, Any] = {"format_version": FORMAT_VERSION, "tool": "reconf", "command": command,
                           "verdict": verdict, "diagnostics": [diagnostic_json(d) for d in diags]}
    doc.update(extra)
    return json.dumps(doc, indent=2, sort_keys=False)


def internal_error(message: str, span: Optional[Span] = None) -> Diagnostic:
    return Diagnostic("RC000", Severity.ERROR, message, span or Span.unknown("<reconf>"))


def timing_note(wall: float, parts: list[tuple[str, float]], details: Optional[dict[str, str]] = None) -> str:
    """`in W s: part p, ...` for a summary line: the wall time and where it went (a part's
    `details` in parentheses after it), what the parts do not cover said as `other`."""
    rest = wall - sum(s for _, s in parts)
    details = details or {}
    shown = [f"{name} {s:.2f}" + (f" ({details[name]})" if name in details else "") for name, s in parts]
    shown += [f"other {rest:.2f}"] if rest >= 0.005 else []
    return f"in {wall:.2f} s: " + ", ".join(shown)


def timing_json(wall: float, parts: list[tuple[str, float]]) -> dict[str, float]:
    """The same as a JSON object: `wall` and each part's seconds under a snake_case key."""
    out = {"wall": round(wall, 4)}
    out.update({name.lower().replace(" ", "_").replace("-", "_"): round(s, 4) for name, s in parts})
    out["other"] = round(max(0.0, wall - sum(s for _, s in parts)), 4)
    return out
