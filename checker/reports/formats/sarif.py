"""SARIF 2.1.0: one run, the diagnostic codes as rule ids, regions from source spans.

Spans name files as reconf shows them (relative to the working directory when under it);
relative URIs are resolved against %SRCROOT%, the working directory. Columns count code
points (`columnKind: unicodeCodePoints`); an end column is exclusive, as in SARIF."""
from __future__ import annotations

import json
import os
import pathlib
from importlib import metadata
from typing import Any, Optional
from urllib.parse import quote

from checker.reports.formats.findings import Report
from checker.reports.formats.sarif_rules import rule
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.span import Span

SCHEMA = "https://json.schemastore.org/sarif-2.1.0.json"
LEVEL = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.NOTE: "note"}


def version() -> str:
    try:
        return metadata.version("reconf")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0"


def artifact_uri(file: str) -> tuple[str, Optional[str]]:
    """(uri, uriBaseId): a relative path against %SRCROOT%, or an absolute file URI."""
    if os.path.isabs(file):
        return pathlib.Path(file).as_uri(), None
    return quote(file.replace(os.sep, "/")), "%SRCROOT%"


def known(span: Optional[Span]) -> bool:
    return span is not None and not span.file.startswith("<") and span.line >= 1


def region(span: Span) -> dict[str, Any]:
    r: dict[str, Any] = {"startLine": span.line, "startColumn": max(1, span.col)}
    if span.end_line >= span.line:
        r["endLine"] = span.end_line
        if span.end_line > span.line or span.end_col > span.col:
            r["endColumn"] = max(1, span.end_col)
    return r


def physical(span: Span) -> dict[str, Any]:
    uri, base = artifact_uri(span.file)
    loc: dict[str, Any] = {"uri": uri}
    if base:
        loc["uriBaseId"] = base
    return {"artifactLocation": loc, "region": region(span)}


def message_text(d: Diagnostic) -> str:
    lines = [d.message]
    lines += ["  " * max(0, r.depth - 1) + "- " + r.message for r in d.related]
    lines += ["note: " + n for n in d.notes]
    return "\n".join(lines)


def result(d: Diagnostic, index: int) -> dict[str, Any]:
    res: dict[str, Any] = {"ruleId": d.code, "ruleIndex": index, "level": LEVEL[d.severity],
                           "message": {"text": message_text(d)}}
    if known(d.span):
        res["locations"] = [{"physicalLocation": physical(d.span)}]
    related = [{"id": i, "physicalLocation": physical(r.span), "message": {"text": r.message}}
               for i, r in enumerate(d.related) if known(r.span)]
    if related:
        res["relatedLocations"] = related
    res["partialFingerprints"] = {"reconfFinding/v1": f"{d.code}:{d.message}"}
    return res


def sarif_log(report: Report) -> dict[str, Any]:
    codes = sorted({d.code for d in report.diagnostics})
    index = {c: i for i, c in enumerate(codes)}
    rules = []
    for c in codes:
        name, text = rule(c)
        level = next(LEVEL[d.severity] for d in report.diagnostics if d.code == c)
        rules.append({"id": c, "name": name, "shortDescription": {"text": text},
                      "defaultConfiguration": {"level": level}})
    run: dict[str, Any] = {
        "tool": {"driver": {"name": "reconf", "version": version(), "semanticVersion": version(),
                            "rules": rules}},
        "originalUriBaseIds": {"%SRCROOT%": {"uri": pathlib.Path(os.getcwd()).as_uri() + "/"}},
        "columnKind": "unicodeCodePoints",
        "invocations": [{"executionSuccessful": report.verdict not in ("error",),
                         "properties": {"command": report.command, "verdict": report.verdict}}],
        "results": [result(d, index[d.code]) for d in report.diagnostics],
    }
    return {"$schema": SCHEMA, "version": "2.1.0", "runs": [run]}


def to_sarif(report: Report) -> str:
    return json.dumps(sarif_log(report), indent=2, ensure_ascii=False) + "\n"
