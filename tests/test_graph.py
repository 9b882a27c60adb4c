"""`reconf graph`: DOT in the rqt_graph look and Mermaid, for every example."""
from __future__ import annotations

import shutil
import subprocess

import pytest
from click.testing import CliRunner

from checker.cli import main
from checker.config import Configuration
from checker.pictures import picture
from codegen.graph import to_dot, to_mermaid
from reconf_dsl.loader import load
from tests.examples_table import BY_NAME, EXAMPLES, Example


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
