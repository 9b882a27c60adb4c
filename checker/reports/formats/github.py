"""GitHub Actions workflow commands: `::error file=…,line=…::message`, one per finding.

Escaping follows the runner's rules: in the message `%`, CR and LF are percent-encoded; in
property values `:` and `,` are too. Severities map to error, warning and notice."""
from __future__ import annotations

from checker.reports.formats.findings import Report
from checker.reports.formats.sarif import known, message_text
from reconf_dsl.diagnostics import Severity

COMMAND = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.NOTE: "notice"}


def escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def escape_property(text: str) -> str:
    return escape_data(text).replace(":", "%3A").replace(",", "%2C")


def to_github(report: Report) -> str:
    out = []
    for d in report.diagnostics:
        props = []
        if known(d.span):
            s = d.span
            props += [f"file={escape_property(s.file)}", f"line={s.line}", f"col={s.col}"]
            if s.end_line >= s.line:
                props.append(f"endLine={s.end_line}")
                if s.end_line > s.line or s.end_col > s.col:
                    props.append(f"endColumn={s.end_col}")
        props.append(f"title={escape_property(f'reconf {d.code}')}")
        out.append(f"::{COMMAND[d.severity]} {','.join(props)}::{escape_data(message_text(d))}")
    if report.summary:
        out.append(f"::notice title=reconf {escape_property(report.command)}::{escape_data(report.summary)}")
    return "".join(line + "\n" for line in out)
