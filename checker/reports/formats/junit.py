"""JUnit XML: one test case per check run (each assumption of each functionality, each gate rule)."""
from __future__ import annotations

import xml.etree.ElementTree as ET

from checker.reports.formats.findings import CheckCase, Report


def to_junit(report: Report) -> str:
    suites: dict[str, list[CheckCase]] = {}
    for case in report.cases:
        suites.setdefault(case.suite, []).append(case)
    root = ET.Element("testsuites", name=f"reconf {report.command}")
    totals = {"tests": 0, "failures": 0, "errors": 0}
    for name, cases in suites.items():
        failures = sum(1 for c in cases if c.failure is not None and not c.error)
        errors = sum(1 for c in cases if c.failure is not None and c.error)
        suite = ET.SubElement(root, "testsuite", name=name, tests=str(len(cases)), failures=str(failures),
                              errors=str(errors), skipped="0")
        totals["tests"] += len(cases)
        totals["failures"] += failures
        totals["errors"] += errors
        for c in cases:
            attrs = {"classname": name, "name": c.name}
            if c.span is not None and not c.span.file.startswith("<"):
                attrs.update(file=c.span.file, line=str(c.span.line))
            tc = ET.SubElement(suite, "testcase", attrs)
            if c.failure is not None:
                el = ET.SubElement(tc, "error" if c.error else "failure", message=c.failure,
                                   type="error" if c.error else "failure")
                el.text = c.details or c.failure
    for k, v in totals.items():
        root.set(k, str(v))
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
