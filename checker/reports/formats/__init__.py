"""Machine-readable reports of `check` and `gate`: SARIF 2.1.0, GitHub workflow commands, JUnit XML.

A command builds one `Report` (its findings as diagnostics, and the list of checks it ran);
`render` turns it into the text of the chosen format, one renderer per format in `RENDERERS`.
Text and JSON stay in `checker.reports.report`."""
from __future__ import annotations

from typing import Callable

from checker.reports.formats.findings import CheckCase, Report, failure_cases
from checker.reports.formats.github import to_github
from checker.reports.formats.junit import to_junit
from checker.reports.formats.sarif import to_sarif

RENDERERS: dict[str, Callable[[Report], str]] = {"sarif": to_sarif, "github": to_github, "junit": to_junit}


def render(report: Report, fmt: str) -> str:
    """The report as `fmt` (sarif, github or junit)."""
    if fmt not in RENDERERS:
        raise ValueError(f"no renderer for {fmt!r}")
    return RENDERERS[fmt](report)


__all__ = ["CheckCase", "RENDERERS", "Report", "render", "failure_cases"]
