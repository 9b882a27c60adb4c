"""Machine-readable reports of `check` and `gate`: SARIF 2.1.0, GitHub workflow commands, JUnit XML.

A command builds one `Report` (its findings as diagnostics, and the list of checks it ran);
`render` turns it into the text of the chosen format. Text and JSON stay in `checker.reports.report`."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from reconf_dsl.diagnostics import Diagnostic
from reconf_dsl.span import Span


@dataclass(frozen=True)
class CheckCase:
    """One check that was run: an assumption of a functionality, or one rule of the gate's policy.

    `failure` is None when it passed; `error` marks a check that could not be run (bad input)."""

    suite: str
    name: str
    failure: Optional[str] = None
    details: str = ""
    span: Optional[Span] = None
    error: bool = False


@dataclass
class Report:
    command: str
    verdict: str
    diagnostics: list[Diagnostic]
    cases: list[CheckCase] = field(default_factory=list)
    summary: str = ""


def render(report: Report, fmt: str) -> str:
    """The report as `fmt` (sarif, github or junit)."""
    if fmt == "sarif":
        from checker.reports.formats.sarif import to_sarif
        return to_sarif(report)
    if fmt == "github":
        from checker.reports.formats.github import to_github
        return to_github(report)
    if fmt == "junit":
        from checker.reports.formats.junit import to_junit
        return to_junit(report)
    raise ValueError(f"no renderer for {fmt!r}")


def failure_cases(command: str, diags: list[Diagnostic]) -> list[CheckCase]:
    """Bad input: one erroneous case per diagnostic, so a JUnit reader shows why nothing was checked."""
    return [CheckCase(f"reconf.{command}", f"{d.code} {d.span}", d.message, "\n".join(d.notes), d.span, error=True)
            for d in diags if d.is_error]


__all__ = ["CheckCase", "Report", "render", "failure_cases"]
