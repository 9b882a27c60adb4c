"""One registry of diagnostic codes (`reconf_dsl.codes`): every code reconf reports is in it,
every code in it is reported somewhere, and the README's table and the SARIF rules are made
from it."""
from __future__ import annotations

import re
from pathlib import Path

from checker.reports.formats.sarif_rules import rule
from reconf_dsl import codes

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("reconf_dsl", "checker", "codegen", "reconf_ros")
CODE = re.compile(r"\bRC\d{3}\b")


def _reported() -> dict[str, list[str]]:
    """Each code a source file names, with the files (the registry itself left out)."""
    out: dict[str, list[str]] = {}
    for pkg in PACKAGES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            if f.name == "codes.py" and f.parent.name == "reconf_dsl":
                continue
            for code in set(CODE.findall(f.read_text(encoding="utf-8"))):
                out.setdefault(code, []).append(str(f.relative_to(ROOT)))
    return out


def test_every_code_reported_is_registered() -> None:
    missing = {code: files for code, files in _reported().items() if code not in codes.BY_CODE}
    assert not missing, f"codes used but not in reconf_dsl/codes.py: {missing}"


def test_every_registered_code_is_reported() -> None:
    reported = _reported()
    assert [c.code for c in codes.CODES if c.code not in reported] == []


def test_the_registry_is_one_row_per_code_in_order() -> None:
    names = [c.code for c in codes.CODES]
    assert names == sorted(set(names))
    assert len({c.name for c in codes.CODES}) == len(codes.CODES)


def test_the_readme_table_is_generated_from_it() -> None:
    assert codes.main(["--check"]) == 0
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert codes.readme_table() in readme


def test_sarif_rules_come_from_it() -> None:
    for c in codes.CODES:
        assert rule(c.code) == (c.name, c.meaning)
