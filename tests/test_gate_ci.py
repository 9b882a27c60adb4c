"""`reconf gate` as a CI pipeline runs it: a fix of an unsafe base, --detailed-exitcode, every
output from one run (--report), and the pull-request comment's picture of what changes."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import checker.gate.comment as gate_comment
from bench.gen import generate
from checker.cli.common import EXIT_CHANGES
from tests.examples_table import BY_NAME
from tests.support.gatekit import gate
from tests.support.sarif import validate_sarif

CHATTER, SLOW, REDUNDANT = BY_NAME["chatter"].file, BY_NAME["chatter_slow"].file, BY_NAME["redundant"].file


# ---------------------------------------------------------------- an unsafe base

def test_a_fix_of_an_unsafe_base_fails_by_default_and_says_how_to_let_it_through(here) -> None:
    code, out, _ = gate("--base", SLOW, "--head", CHATTER)
    assert code == 1
    doc = json.loads(out)
    (d,) = doc["diagnostics"]
    assert d["code"] == "RC509" and d["severity"] == "error"
    assert "the base chatter is not safe" in d["message"] and "chatter is safe" in d["message"]
    assert d["notes"] == [
        "listener.listen assumes String @ 10 Hz, which does not hold",
        "if this change fixes the base, let it through with --allow-unsafe-base or allow-unsafe-base = true in the "
        "policy: the gate then judges the head alone, and the change must be deployed by other means (a restart, a "
        "maintenance window), as no safe step-by-step plan from the deployed configuration exists"]
    assert d["span"]["file"].endswith("chatter_slow.arch")
    assert doc["safe"] is True and doc["base_safe"] is False


def test_the_flag_lets_a_fix_through_with_a_warning(here) -> None:
    code, out, _ = gate("--base", SLOW, "--head", CHATTER, "--allow-unsafe-base", fmt="sarif")
    assert code == 0
    (r,) = validate_sarif(out)["runs"][0]["results"]
    assert r["ruleId"] == "RC510" and r["level"] == "warning"
    assert "deploy it by other means" in r["message"]["text"]
    code, _, _ = gate("--base", SLOW, "--head", CHATTER, "--allow-unsafe-base", "--detailed-exitcode")
    assert code == EXIT_CHANGES      # something is to be deployed, by other means


def test_the_policy_key_lets_a_fix_through(here) -> None:
    (here / "reconf.toml").write_text("allow-unsafe-base = true\n", encoding="utf-8")
    code, out, err = gate("--base", SLOW, "--head", CHATTER, fmt="text")
    assert code == 0, out
    assert "warning[RC510]" in err and "allow-unsafe-base = true in the policy in reconf.toml" in err


def test_an_unsafe_head_still_fails_when_unsafe_bases_are_allowed(here) -> None:
    code, out, _ = gate("--base", SLOW, "--head", SLOW, "--allow-unsafe-base")
    assert code == 1
    codes = {d["code"] for d in json.loads(out)["diagnostics"]}
    assert codes == {"RC201", "RC507"}


# ---------------------------------------------------------------- --detailed-exitcode

def test_detailed_exitcode(here) -> None:
    assert gate("--base", CHATTER, "--head", CHATTER, "--detailed-exitcode")[0] == 0        # nothing to do
    assert gate("--base", CHATTER, "--head", REDUNDANT, "--detailed-exitcode")[0] == 3      # safe, with steps
    assert gate("--base", CHATTER, "--head", SLOW, "--detailed-exitcode")[0] == 1           # unsafe
    assert gate("--base", CHATTER, "--head", "none.arch", "--detailed-exitcode")[0] == 2    # bad input
    # without the flag, as before
    assert gate("--base", CHATTER, "--head", REDUNDANT)[0] == 0
    (here / "reconf.toml").write_text("max-disruption = 0\n", encoding="utf-8")
    assert gate("--base", CHATTER, "--head", REDUNDANT, "--detailed-exitcode")[0] == 1      # over the policy


# ---------------------------------------------------------------- every output from one run

def test_one_run_writes_every_report(here) -> None:
    (here / "out").mkdir()
    code, out, _ = gate("--base", CHATTER, "--head", SLOW, "--report", "sarif=out/gate.sarif",
                        "--report", "markdown=gate.md", "--report", "junit=gate.xml", "--report", "json=gate.json",
                        fmt="github")
    assert code == 1
    assert out.startswith("::error file=") and "RC201" in out
    sarif = validate_sarif((here / "out" / "gate.sarif").read_text(encoding="utf-8"))
    assert {r["ruleId"] for r in sarif["runs"][0]["results"]} == {"RC201", "RC507"}
    assert ET.fromstring((here / "gate.xml").read_text(encoding="utf-8")).get("failures") == "2"
    assert json.loads((here / "gate.json").read_text(encoding="utf-8"))["verdict"] == "fail"
    md = (here / "gate.md").read_text(encoding="utf-8")
    assert md.splitlines()[0] == gate_comment.marker(SLOW)
    assert "architecture gate failed" in md and "**RC201**" in md


def test_reports_stay_valid_on_bad_input(here) -> None:
    (here / "reconf.toml").write_text('never-degrade = ["detectt"]\n', encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT, "--report", "sarif=gate.sarif",
                        "--report", "markdown=gate.md", "--report", "junit=gate.xml", "--report", "json=gate.json")
    assert code == 2
    assert json.loads(out)["verdict"] == "error"
    (r,) = validate_sarif((here / "gate.sarif").read_text(encoding="utf-8"))["runs"][0]["results"]
    assert r["ruleId"] == "RC508"
    assert ET.fromstring((here / "gate.xml").read_text(encoding="utf-8")).get("errors") == "1"
    assert json.loads((here / "gate.json").read_text(encoding="utf-8"))["diagnostics"][0]["code"] == "RC508"
    md = (here / "gate.md").read_text(encoding="utf-8")
    assert md.startswith(gate_comment.marker(REDUNDANT)) and "could not judge" in md and "RC508" in md


def test_a_report_that_cannot_be_written_is_bad_input(here) -> None:
    code, out, _ = gate("--base", CHATTER, "--head", CHATTER, "--report", "sarif=no/such/dir/gate.sarif")
    assert code == 2
    (d,) = json.loads(out)["diagnostics"]
    assert d["code"] == "RC511" and "no/such/dir/gate.sarif" in d["message"]


def test_a_report_that_cannot_be_written_leaves_the_others_as_judged(here) -> None:
    code, out, err = gate("--base", CHATTER, "--head", CHATTER, "--report", "json=ok.json",
                          "--report", "sarif=no/such/dir/gate.sarif")
    assert code == 2 and (out + err).count('"RC511"') == 1, out + err      # said once, not again by a fallback
    with open(here / "ok.json", encoding="utf-8") as f:
        assert json.load(f)["verdict"] == "pass"


def test_a_bad_report_option_is_a_usage_error(here) -> None:
    code, _, err = gate("--base", CHATTER, "--head", CHATTER, "--report", "pdf=gate.pdf")
    assert code == 2 and "FORMAT=FILE" in err


# ---------------------------------------------------------------- the picture of what changes

@pytest.fixture(scope="module")
def dag300(tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("dag")
    text = generate("dag", 300, version=True)
    (d / "base.arch").write_text(text, encoding="utf-8")
    # c150 runs with other arguments: a new process, so the plan replaces it
    changed = text.replace('-r __node:=c150"', '-r __node:=c150 --log-level debug"', 1)
    assert changed != text
    (d / "head.arch").write_text(changed, encoding="utf-8")
    return d / "base.arch", d / "head.arch"


def mermaid_blocks(md: str) -> list[str]:
    return [b.split("```", 1)[0] for b in md.split("```mermaid\n")[1:]]


def test_the_picture_shows_the_changed_neighbourhood_of_a_300_component_system(here, dag300) -> None:
    from checker.planning import plan_migrate
    from checker.reports.pictures import plan_picture
    from codegen.graph import to_mermaid
    from reconf_dsl.loader import load
    base, head = dag300
    whole = to_mermaid(plan_picture(plan_migrate(load([str(base)]), load([str(head)]))))
    assert len(whole) > gate_comment.MERMAID_LIMIT        # the whole system would not be drawn at all
    code, _, err = gate("--base", str(base), "--head", str(head), "--report", "markdown=gate.md")
    assert code == 0, err
    md = (here / "gate.md").read_text(encoding="utf-8")
    (block,) = mermaid_blocks(md)
    assert len(block) < 5_000 and len(md) < gate_comment.COMMENT_LIMIT
    assert '("c150' in block and '("c150@new' in block
    shown = block.count('("')                              # components are drawn with round brackets
    assert 3 <= shown < 30
    assert "(15 of 300 components" in md


def test_a_picture_over_the_limit_is_left_out_and_said(here, dag300, monkeypatch) -> None:
    monkeypatch.setattr(gate_comment, "MERMAID_LIMIT", 500)
    base, head = dag300
    code, _, _ = gate("--base", str(base), "--head", str(head), "--report", "markdown=gate.md")
    assert code == 0
    md = (here / "gate.md").read_text(encoding="utf-8")
    assert not mermaid_blocks(md)
    assert "over Mermaid's limit of 500" in md and "reconf graph-plan" in md


def test_neighbourhood_keeps_changed_components_their_topics_and_the_components_on_them() -> None:
    from codegen.graph import GraphEdge, GraphNode, Picture
    pic = Picture("p", [GraphNode("c:a", "a", "ellipse", "created"), GraphNode("c:b", "b", "ellipse"),
                        GraphNode("c:far", "far", "ellipse"), GraphNode("t:x", "x", "box"),
                        GraphNode("t:y", "y", "box"), GraphNode("e:env", "env", "note")],
                  [GraphEdge("c:a", "t:x", "out", "created"), GraphEdge("t:x", "c:b", "in"),
                   GraphEdge("c:b", "t:y", "out"), GraphEdge("t:y", "c:far", "in")])
    part = gate_comment.neighbourhood(pic)
    assert [n.id for n in part.nodes] == ["c:a", "c:b", "t:x"]
    assert [(e.source, e.target) for e in part.edges] == [("c:a", "t:x"), ("t:x", "c:b")]


def test_the_comment_stays_under_githubs_limit_whatever_it_holds() -> None:
    from checker.gate.comment import COMMENT_LIMIT, comment, failure_comment
    from reconf_dsl.diagnostics import error
    from reconf_dsl.span import Span
    many = [error("RC201", "x" * 200, Span("a.arch", i + 1, 1, i + 1, 2)) for i in range(2_000)]
    text = comment(verdict="fail", base="a", head="b", diagnostics=many, summary="s", notes=("n" * 70_000,))
    assert len(text) <= COMMENT_LIMIT and "cut at GitHub's limit" in text
    assert "1 error: nothing was judged" in failure_comment("a", "b", many[:1])
