"""The Python safety engine and `reconf check` on the shared example table."""
from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl.loader import load, load_text
from tests.examples_table import EXAMPLES, Example


@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_verdict_matches_table(ex: Example) -> None:
    system = load([ex.file])
    ev = evaluate(system, Configuration.initial(system))
    assert ev.valid is ex.safe
    assert {f"{r.component}.{r.functionality}" for r in ev.unsatisfied} == ex.unsatisfied


@pytest.mark.alloy
@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_cli_exit_code_and_json(ex: Example) -> None:
    result = CliRunner().invoke(main, ["check", ex.file, "--output-format", "json"])
    assert result.exit_code == (0 if ex.safe else 1), result.output
    doc = json.loads(result.stdout)
    assert doc["format_version"] == 1
    assert doc["verdict"] == ("safe" if ex.safe else "unsafe")
    failing = {f"{a['component']}.{a['functionality']}" for a in doc["assumptions"] if not a["holds"]}
    assert failing == ex.unsatisfied
    assert all(d["code"] == "RC201" for d in doc["diagnostics"])


@pytest.mark.alloy
def test_chain_explains_rate_too_low() -> None:
    result = CliRunner().invoke(main, ["check", EXAMPLES[1].file])
    text = result.stderr
    assert "error[RC201]: listener.listen assumes String @ 10 Hz, which does not hold" in text
    assert "input listener.in assumes String @ 10 Hz" in text
    assert "topic /chatter guarantees String @ 10 Hz, but no attached output satisfies it" in text
    assert "talk guarantees String @ 5 Hz: rate too low: 5 Hz < 10 Hz" in text
    assert "chatter_slow.arch:10:3" in text  # the span of the output's functionality


def test_chain_explains_missing_publisher_and_degraded() -> None:
    system = load([EXAMPLES[0].file])
    config = Configuration.initial(system)
    degraded = Configuration(config.components, frozenset({("talker", "talk")}), config.roles)
    ev = evaluate(system, degraded)
    assert not ev.valid
    texts = [link.text for link in ev.unsatisfied[0].chain]
    assert texts == ["listener.listen (normal mode)", "assumes String @ 10 Hz",
                     "input listener.in assumes String @ 10 Hz",
                     "topic /chatter guarantees String @ 10 Hz, but no attached output satisfies it",
                     "output talker.out: talk is degraded and guarantees nothing: it provides nothing",
                     "no environment guarantee provides String"]
    detached = Configuration(config.components, frozenset(), frozenset())
    texts = [link.text for link in evaluate(system, detached).unsatisfied[0].chain]
    assert texts == ["listener.listen (normal mode)", "assumes String @ 10 Hz",
                     "input listener.in is attached to nothing",
                     "no environment guarantee provides String"]


BASE = """system s
message M = std_msgs/msg/String
message N = std_msgs/msg/Int32
{extra}
component p {{
  output out: M
  functionality f (out) {{
    normal {{ out: {guar} }}
    degraded {{ out: nothing }}
  }}
}}
component c {{
  input in: {inasm}
  functionality g (in) {{
    normal {{ assume {asm} }}
    degraded {{ }}
  }}
}}
topic /t: {conn} {{ p.out -> c.in }}
"""


@pytest.mark.parametrize("guar,conn,inasm,asm,extra,safe", [
    ("M @ 10 Hz", "M @ 10 Hz", "M @ 10 Hz", "M @ 10 Hz", "", True),
    ("M @ 20 Hz", "M @ 10 Hz", "M @ 5 Hz", "M", "", True),           # rates only need to be high enough
    ("M", "M @ 10 Hz", "M @ 10 Hz", "M @ 10 Hz", "", False),          # a rate-less guarantee meets no rate
    ("M @ 10 Hz", "M", "M @ 10 Hz", "M @ 10 Hz", "", False),          # the connector promises no rate
    ("M @ 10 Hz", "M @ 10 Hz", "M @ 5 Hz", "M @ 10 Hz", "", False),   # the input's assumption is too weak
    ("M @ 100 ms", "M @ 10 Hz", "M @ 0.01 kHz", "M @ 10 Hz", "", True),  # units are exact
    ("M @ 9 Hz", "M @ 10 Hz", "M @ 10 Hz", "N @ 1 Hz", "environment e: N @ 2 Hz", True),  # environment
    ("M @ 9 Hz", "M @ 10 Hz", "M @ 10 Hz", "N @ 1 Hz", "environment e: N @ 0.5 Hz", False),
])
def test_satisfaction_rules(guar: str, conn: str, inasm: str, asm: str, extra: str, safe: bool) -> None:
    system = load_text(BASE.format(guar=guar, conn=conn, inasm=inasm, asm=asm, extra=extra), "s.arch")
    assert evaluate(system, Configuration.initial(system)).valid is safe


def test_redundant_publisher_keeps_topic_satisfied() -> None:
    system = load([path_of("redundant")])
    config = Configuration.initial(system)
    one_down = Configuration(config.components, frozenset({("lidar_front", "sense")}), config.roles)
    assert evaluate(system, one_down).valid
    both_down = Configuration(config.components, frozenset({("lidar_front", "sense"), ("lidar_rear", "sense")}),
                              config.roles)
    assert not evaluate(system, both_down).valid


def path_of(name: str) -> str:
    from tests.examples_table import BY_NAME
    return BY_NAME[name].file


@pytest.mark.alloy
def test_a_thousand_components_are_judged_by_alloy_in_slices(tmp_path: "object") -> None:
    import os

    from bench.gen import generate
    path = os.path.join(str(tmp_path), "big.arch")
    with open(path, "w") as f:
        f.write(generate("fanin", 1000, 1, unsafe=True))
    result = CliRunner().invoke(main, ["check", path, "--output-format", "json"])
    assert result.exit_code == 1, result.output
    doc = json.loads(result.stdout)
    alloy = doc["engines"]["alloy"]
    assert alloy["verdict"] == "unsafe" and alloy["unsatisfied"], alloy
    assert [d["code"] for d in doc["diagnostics"]] and all(d["code"] == "RC201" for d in doc["diagnostics"])


def test_too_large_for_alloy_falls_back_to_python_with_a_warning(monkeypatch: "object") -> None:
    import checker.alloy.engines
    from checker.alloy import AlloyError

    def too_large(*args: object, **kwargs: object) -> None:
        # what the analyzer says when a module's atoms exceed what it can index
        raise AlloyError("Translation capacity exceeded. In this scope, universe contains 50000 atoms")

    monkeypatch.setattr(checker.alloy.engines, "PendingVerdict", too_large)
    path = path_of("chatter")
    result = CliRunner().invoke(main, ["check", path, "--output-format", "json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["engines"]["alloy"]["verdict"] == "not run"
    assert doc["diagnostics"][0]["code"] == "RC303" and doc["diagnostics"][0]["severity"] == "warning"
    result = CliRunner().invoke(main, ["check", path, "--engine", "alloy"])
    assert result.exit_code == 2 and "RC303" in result.stderr


@pytest.mark.alloy
def test_the_summary_says_where_the_time_went() -> None:
    """The wall time from the process's start and its parts, in the line and in JSON."""
    result = CliRunner().invoke(main, ["check", path_of("chatter"), "--output-format", "json"])
    timing = json.loads(result.stdout)["timing"]
    parts = {k: v for k, v in timing.items() if k not in ("wall", "other")}
    assert {"start_up", "parsing", "python_engine", "alloy_start", "rendering", "alloy"} <= parts.keys(), timing
    assert all(v >= 0 for v in timing.values())
    assert sum(parts.values()) <= timing["wall"] + 1e-3
    text = CliRunner().invoke(main, ["check", path_of("chatter")]).output
    assert re.search(r"; in \d+\.\d\d s: start-up \d+\.\d\d \(cold\), parsing \d+\.\d\d, rendering \d+\.\d\d, "
                     r"Python engine \d+\.\d\d, Alloy start \d+\.\d\d, Alloy \d+\.\d\d \(1 instance, read \d+\.\d\d s, "
                     r"evaluated \d+\.\d\d s\)", text), text


def test_check_takes_the_arch_files_under_a_directory(tmp_path: "object") -> None:
    """A system split over files: the directory stands for all of them; --exclude leaves some out."""
    import pathlib
    root = pathlib.Path(str(tmp_path))
    files = {"system.arch": "system s\ncomponent talker {\n  output out: M\n  functionality talk (out) {\n"
                            "    normal { out: M @ 10 Hz }\n    degraded { out: nothing }\n  }\n}\n"
                            "topic /t: M @ 10 Hz { talker.out -> }\n",
             "types/messages.arch": "message M = std_msgs/msg/String\n",
             "drafts/broken.arch": "component {\n",
             ".old/broken.arch": "component {\n",
             "README.txt": "not an architecture\n"}
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    r = CliRunner().invoke(main, ["check", "--engine", "python", str(root), "--exclude", "drafts"])
    assert r.exit_code == 0, r.stderr
    assert "safe" in r.stderr and "1 component" in r.stderr
    r = CliRunner().invoke(main, ["check", "--engine", "python", str(root)])
    assert r.exit_code == 2
    assert re.search(r"drafts/broken\.arch:1:11: error\[RC001\]", r.stderr), r.stderr
    assert ".old" not in r.stderr
    r = CliRunner().invoke(main, ["check", "--engine", "python", str(root / "drafts"), "--exclude", "*.arch"])
    assert r.exit_code == 2 and "error[RC007]" in r.stderr and "--exclude left out every file" in r.stderr
    (root / "empty").mkdir()
    r = CliRunner().invoke(main, ["check", "--engine", "python", str(root / "empty")])
    assert r.exit_code == 2 and "error[RC007]: no .arch file under" in r.stderr
