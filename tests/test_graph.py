"""`reconf graph` and `graph-plan`: DOT in the rqt_graph look and Mermaid, for every example; SVG's size
limit, the format an output file's extension says, and a plan's pictures one file a step."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import Optional

import pytest
from click.testing import CliRunner

from checker.cli import common  # draws SVG through its own name for pictures.to_svg
from checker.cli.main import main
from checker.reports import pictures
from checker.reports.pictures import picture
from checker.semantic_model.config import Configuration
from codegen.graph import GraphNode, Picture, to_dot, to_mermaid
from reconf_dsl.loader import load
from tests.examples_table import BY_NAME, EXAMPLES, ROOT, Example


@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_dot_for_every_example(ex: Example) -> None:
    result = CliRunner().invoke(main, ["graph", ex.file])
    assert result.exit_code == 0, result.stderr
    dot = result.stdout
    assert dot.startswith("digraph ")
    system = load([ex.file])
    for c in system.components:
        assert f'"c:{c.name}" [label="{c.name}", shape=ellipse' in dot
    for t in system.connectors:
        assert f'"t:{t.name}"' in dot and "shape=box" in dot
    if shutil.which("dot"):
        subprocess.run(["dot", "-Tsvg"], input=dot, text=True, check=True, capture_output=True)


def test_degraded_component_is_orange_and_edges_follow_data() -> None:
    system = load([BY_NAME["chatter"].file])
    config = Configuration.initial(system)
    config = Configuration(config.components, frozenset({("listener", "listen")}), config.roles)
    dot = to_dot(picture(system, config))
    assert '"c:listener" [label="listener", shape=ellipse, fillcolor="#ffb347"' in dot
    assert '"c:talker" -> "t:/chatter" [label="out"]' in dot
    assert '"t:/chatter" -> "c:listener" [label="in"]' in dot


def test_mermaid() -> None:
    result = CliRunner().invoke(main, ["graph", "--format", "mermaid", BY_NAME["robot"].file])
    assert result.exit_code == 0
    text = result.stdout
    assert text.startswith("flowchart LR\n")
    assert '("obstacle_detector")' in text
    assert '["/obstacles<br/>Obstacles @ 1 Hz"]' in text
    system = load([BY_NAME["robot"].file])
    pic = picture(system, removed=frozenset({"base_driver"}))
    assert "class n0 removed" in to_mermaid(pic)


def test_graph_bad_input_exits_2() -> None:
    result = CliRunner().invoke(main, ["graph", "tests/bad_inputs/unknown_unit.arch"])
    assert result.exit_code == 2 and "RC114" in result.stderr


# -- SVG of a large picture ---------------------------------------------------------------------

def _no_dot(dot: str) -> str:
    raise AssertionError("Graphviz must not be run on a picture over the limit")


def test_svg_over_the_limit_is_refused_with_what_to_do(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from bench.gen import generate
    monkeypatch.setattr(common, "to_svg", _no_dot)
    arch = tmp_path / "dag.arch"
    arch.write_text(generate("dag", 150), encoding="utf-8")
    nodes = len(picture(load([str(arch)])).nodes)
    assert nodes > pictures.SVG_MAX_NODES
    result = CliRunner().invoke(main, ["graph", str(arch), "--format", "svg"])
    assert result.exit_code == 2, result.output
    assert "error[RC012]" in result.stderr and f"{nodes:,} nodes" in result.stderr
    assert str(pictures.SVG_MAX_NODES) in result.stderr
    assert "--format dot" in result.stderr and "--force" in result.stderr
    assert "Traceback" not in result.output and result.stdout == ""
    # DOT and Mermaid of the same system are text: no limit
    assert CliRunner().invoke(main, ["graph", str(arch)]).exit_code == 0


def test_force_draws_svg_over_the_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from bench.gen import generate
    drawn: list[str] = []

    def fake(dot: str) -> str:
        drawn.append(dot)
        return "<svg/>\n"
    monkeypatch.setattr(common, "to_svg", fake)
    arch = tmp_path / "dag.arch"
    arch.write_text(generate("dag", 150), encoding="utf-8")
    result = CliRunner().invoke(main, ["graph", str(arch), "--format", "svg", "--force"])
    assert result.exit_code == 0, result.output
    assert result.stdout == "<svg/>\n" and len(drawn) == 1


def _picture_of(nodes: int) -> Picture:
    return Picture("p", [GraphNode(f"c:{i}", str(i), "ellipse") for i in range(nodes)])


def test_the_limit_is_on_the_largest_picture(monkeypatch: pytest.MonkeyPatch) -> None:
    from checker.cli.common import Failure, draw
    monkeypatch.setattr(common, "to_svg", lambda dot: "<svg/>")
    limit = pictures.SVG_MAX_NODES
    assert draw([_picture_of(limit), _picture_of(3)], "svg") == "<svg/><svg/>"
    with pytest.raises(Failure) as refused:
        draw([_picture_of(3), _picture_of(limit + 1)], "svg")
    assert refused.value.diagnostics[0].code == "RC012"
    assert draw([_picture_of(limit + 1)], "svg", force=True) == "<svg/>"
    assert draw([_picture_of(limit + 1)], "dot").startswith("digraph ")


# -- the format of an output file ---------------------------------------------------------------

@pytest.mark.parametrize("name, given, written", [
    ("out.dot", None, "dot"), ("out.gv", None, "dot"), ("out.mmd", None, "mermaid"), ("out.md", None, "markdown"),
    ("out.MMD", None, "mermaid"), ("out.txt", None, "dot"), ("out", "mermaid", "mermaid"),
    ("out.dot", "dot", "dot"), ("out.gv", "dot", "dot"), ("out.md", "markdown", "markdown"),
    ("out.txt", "markdown", "markdown"),
])
def test_the_format_follows_the_extension(tmp_path: Path, name: str, given: Optional[str], written: str) -> None:
    out = tmp_path / name
    args = ["graph", BY_NAME["chatter"].file, "-o", str(out)] + (["--format", given] if given else [])
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    text = out.read_text(encoding="utf-8")
    start = {"dot": "digraph ", "mermaid": "flowchart LR", "markdown": "```mermaid"}[written]
    assert text.startswith(start), text[:40]


@pytest.mark.parametrize("name, given, words", [
    ("x.png", "svg", ["-o x.png asks for PNG", "(--format svg writes SVG)", "name the file x.svg",
                      "`dot -Tpng x.dot -o x.png`"]),
    ("x.png", None, ["-o x.png asks for PNG, which reconf does not draw;"]),
    ("x.PDF", "dot", ["-o x.PDF asks for PDF", "name the file x.dot"]),
    ("x.svg", "dot", ["-o x.svg says SVG, but --format dot writes Graphviz DOT source", "name the file x.dot",
                      "leave out --format to write SVG"]),
    ("x.dot", "mermaid", ["-o x.dot says Graphviz DOT source, but --format mermaid", "name the file x.mmd"]),
    ("x.md", "svg", ["-o x.md says Markdown", "name the file x.svg"]),
    ("x.mmd", "markdown", ["-o x.mmd says a Mermaid diagram", "name the file x.md"]),
])
def test_an_extension_that_contradicts_the_format_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                            name: str, given: Optional[str], words: list[str]) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(common, "to_svg", _no_dot)
    for command in (["graph", BY_NAME["chatter"].file],
                    ["graph-plan", BY_NAME["chatter"].file, os.path.join(ROOT, "examples", "chatter_migrated.arch")]):
        result = CliRunner().invoke(main, command + ["-o", name] + (["--format", given] if given else []))
        assert result.exit_code == 2, result.output
        assert "error[RC013]" in result.stderr and "Traceback" not in result.output
        for w in words:
            assert w in result.stderr
        assert os.listdir(tmp_path) == []


# -- a plan's pictures, one file a step ---------------------------------------------------------

def test_steps_remove_the_numbered_files_of_an_earlier_longer_plan(tmp_path: Path) -> None:
    old, new = BY_NAME["chatter"].file, os.path.join(ROOT, "examples", "chatter_migrated.arch")
    out = tmp_path / "out.dot"
    result = CliRunner().invoke(main, ["graph-plan", old, new, "--steps", "--strategy", "paper", "-o", str(out)])
    assert result.exit_code == 0, result.output
    longer = sorted(p.name for p in tmp_path.iterdir())
    assert len(longer) > 3 and longer[0] == "out-01.dot"
    # files of the same stem and extension that are not the series' own names are kept
    others = ["out-007.dot", "out-1.dot", "out-00.dot", "out-09.svg", "out.dot", "outx-09.dot", "out-09.dot.bak",
              "out-09-1.dot"]
    for name in others:
        (tmp_path / name).write_text("mine\n", encoding="utf-8")
    result = CliRunner().invoke(main, ["graph-plan", old, new, "--steps", "-o", str(out)])
    assert result.exit_code == 0, result.output
    shorter = sorted(p.name for p in (tmp_path).iterdir() if p.name not in others)
    assert len(shorter) < len(longer)
    assert shorter == [f"out-{i:02d}.dot" for i in range(1, len(shorter) + 1)]
    gone = [n for n in longer if n not in shorter]
    assert f"removed {len(gone)} step files of an earlier, longer plan" in " ".join(result.stderr.split())
    for name in others:
        assert (tmp_path / name).read_text(encoding="utf-8") == "mine\n"
    # a single step is still numbered, and a plan with nothing to do leaves one picture saying so
    result = CliRunner().invoke(main, ["graph-plan", old, old, "--steps", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in tmp_path.iterdir() if p.name not in others) == ["out-01.dot"]
    assert "nothing to do" in (tmp_path / "out-01.dot").read_text(encoding="utf-8")
    assert f"removed {len(shorter) - 1} step files of an earlier, longer plan" in " ".join(result.stderr.split())
    (tmp_path / "out-02.dot").write_text("", encoding="utf-8")
    result = CliRunner().invoke(main, ["graph-plan", old, old, "--steps", "-o", str(out)])
    assert "removed 1 step file of an earlier, longer plan" in " ".join(result.stderr.split())


def test_stale_matches_only_the_series_names(tmp_path: Path) -> None:
    for name in ["a-01.svg", "a-02.svg", "a-10.svg", "a-100.svg", "a-007.svg", "a-0.svg", "a-00.svg", "a-3.svg",
                 "a-04.SVG", "b-05.svg", "a-05.svg.tmp"]:
        (tmp_path / name).write_text("", encoding="utf-8")
    out = str(tmp_path / "a.svg")
    left = pictures.stale(out, pictures.series(out, 2))
    assert [os.path.basename(p) for p in left] == ["a-10.svg", "a-100.svg"]
