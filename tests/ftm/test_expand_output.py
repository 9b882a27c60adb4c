"""`reconf ftm expand -o`: the format follows the file's extension; one that contradicts --format
is refused (DOT after the DSL in an .arch file would not parse back)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import pytest
from click.testing import CliRunner

from checker.cli.ftm_cmd import ftm_group
from reconf_dsl.loader import load
from tests.support.ftm import EXAMPLES

SOURCE = f"{EXAMPLES}/client_server_pbr.arch"


@pytest.mark.parametrize("name, given, dsl, dot", [
    ("x.arch", None, True, False), ("x.dot", None, False, True), ("x.GV", None, False, True),
    ("x.txt", None, True, True), ("x.arch", "dsl", True, False), ("x.txt", "dot", False, True),
])
def test_the_format_follows_the_extension(tmp_path: Path, name: str, given: Optional[str], dsl: bool,
                                          dot: bool) -> None:
    out = tmp_path / name
    r = CliRunner().invoke(ftm_group, ["expand", SOURCE, "-o", str(out)] + (["--format", given] if given else []))
    assert r.exit_code == 0, r.output
    text = out.read_text(encoding="utf-8")
    assert ("digraph " in text) == dot and text.startswith("digraph ") == (dot and not dsl)
    if not dot:
        assert load([str(out)]).name == "client_server"


@pytest.mark.parametrize("name, given, words", [
    ("x.arch", "both", "-o x.arch says DSL text, but --format both writes DSL text and DOT"),
    ("x.arch", "dot", "name the file x.dot"),
    ("x.dot", "dsl", "-o x.dot says Graphviz DOT source, but --format dsl writes DSL text; name the file x.arch"),
])
def test_a_contradiction_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, given: str,
                                    words: str) -> None:
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(ftm_group, ["expand", SOURCE, "-o", name, "--format", given])
    assert r.exit_code == 2, r.output
    assert "error[RC013]" in r.stderr and words in r.stderr and "Traceback" not in r.output
    assert list(tmp_path.iterdir()) == []
