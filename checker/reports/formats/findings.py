"""What a machine-readable report holds: the command's findings as diagnostics, and the checks it ran."""
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


def failure_cases(command: str, diags: list[Diagnostic]) -> list[CheckCase]:
    """Bad input: one erroneous case per diagnostic, so a JUnit reader shows why nothing was checked."""
    return [CheckCase(f"reconf.{command}", f"{d.code} {d.span}", d.message, "\n".join(d.notes), d.span, error=True)
            for d in diags if d.is_error]
