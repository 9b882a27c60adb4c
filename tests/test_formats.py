"""`--output-format sarif|github|junit` of `check`: SARIF valid against the 2.1.0 schema,
GitHub annotations escaped, JUnit with one case per checked assumption."""
from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET

import jsonschema
import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.reports.formats import Report
from checker.reports.formats.github import escape_data, escape_property, to_github
from checker.reports.progress import enabled
from reconf_dsl.diagnostics import Related, error
from reconf_dsl.span import Span
from tests.examples_table import BY_NAME, EXAMPLES, Example
from tests.support.sarif import sarif_schema, validate_sarif


@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_sarif_for_every_example(ex: Example) -> None:
    result = CliRunner().invoke(main, ["check", ex.file, "--output-format", "sarif", "--engine", "python"])
    assert result.exit_code == (0 if ex.safe else 1), result.output
    doc = validate_sarif(result.stdout)
    results = doc["runs"][0]["results"]
    assert len(results) == len(ex.unsatisfied)
    rules = [r["id"] for r in doc["runs"][0]["tool"]["driver"]["rules"]]
    for r in results:
        assert r["ruleId"] == "RC201" and rules[r["ruleIndex"]] == "RC201"
        assert r["level"] == "error"


@pytest.mark.alloy
def test_sarif_region_is_the_assumption() -> None:
    result = CliRunner().invoke(main, ["check", BY_NAME["chatter_slow"].file, "--output-format", "sarif"])
    doc = validate_sarif(result.stdout)
    (r,) = doc["runs"][0]["results"]
    loc = r["locations"][0]["physicalLocation"]
    assert loc["artifactLocation"]["uri"].endswith("examples/chatter_slow.arch")
    assert loc["region"] == {"startLine": 21, "startColumn": 21, "endLine": 21, "endColumn": 35}
    related = [(rl["physicalLocation"]["region"]["startLine"], rl["message"]["text"]) for rl in r["relatedLocations"]]
    assert related[:3] == [(18, "input listener.in assumes String @ 10 Hz"),
                           (26, "topic /chatter guarantees String @ 10 Hz, but no attached output satisfies it"),
                           (10, "output talker.out: talk guarantees String @ 5 Hz: rate too low: 5 Hz < 10 Hz")]


def test_sarif_for_bad_input_is_valid(tmp_path) -> None:
    bad = tmp_path / "bad.arch"
    bad.write_text("system x\ncomponent {\n", encoding="utf-8")
    result = CliRunner().invoke(main, ["check", str(bad), "--output-format", "sarif"])
    assert result.exit_code == 2
    doc = validate_sarif(result.stdout)
    assert doc["runs"][0]["results"] and doc["runs"][0]["invocations"][0]["executionSuccessful"] is False


def test_schema_rejects_what_it_should() -> None:
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"version": "2.1.0", "runs": [{"tool": {"driver": {"name": "x"}},
                                                           "results": [{"level": "fatal", "message": {"text": "m"}}]}]},
                            sarif_schema())


def test_github_annotations_escape() -> None:
    assert escape_data("50% done\r\nnext") == "50%25 done%0D%0Anext"
    assert escape_property("a:b,c%") == "a%3Ab%2Cc%25"
    d = error("RC201", "x: 100% wrong,\nreally", Span("dir,1/a:b.arch", 3, 5, 3, 9),
              related=(Related(Span("a.arch", 1, 1, 1, 2), "because"),))
    text = to_github(Report("check", "unsafe", [d]))
    assert text == ("::error file=dir%2C1/a%3Ab.arch,line=3,col=5,endLine=3,endColumn=9,title=reconf RC201::"
                    "x: 100%25 wrong,%0Areally%0A- because\n")


@pytest.mark.alloy
def test_github_format_of_check() -> None:
    result = CliRunner().invoke(main, ["check", BY_NAME["chatter_slow"].file, "--output-format", "github"])
    assert result.exit_code == 1
    first = result.stdout.splitlines()[0]
    assert first.startswith("::error file=examples/chatter_slow.arch,line=21,col=21,")
    assert "title=reconf RC201::listener.listen assumes String @ 10 Hz" in first


@pytest.mark.alloy
@pytest.mark.parametrize("name", ["robot", "robot_slow"])
def test_junit_one_case_per_assumption(name: str) -> None:
    ex = BY_NAME[name]
    result = CliRunner().invoke(main, ["check", ex.file, "--output-format", "junit"])
    root = ET.fromstring(result.stdout)
    js = json.loads(CliRunner().invoke(main, ["check", ex.file, "--output-format", "json"]).stdout)
    cases = root.findall(".//testcase")
    assert len(cases) == len(js["assumptions"]) == int(root.get("tests", "0"))
    failed = {c.get("classname") for c in cases if c.find("failure") is not None}
    assert {n.split(".", 1)[1] for n in failed} == ex.unsatisfied
    assert int(root.get("failures", "0")) == sum(1 for a in js["assumptions"] if not a["holds"])


def test_junit_for_bad_input(tmp_path) -> None:
    result = CliRunner().invoke(main, ["check", str(tmp_path / "missing.arch"), "--output-format", "junit"])
    assert result.exit_code == 2
    root = ET.fromstring(result.stdout)
    assert root.get("errors") == "1" and root.find(".//error") is not None


def test_progress_only_for_people() -> None:
    class Tty:
        def isatty(self) -> bool:
            return True

    assert enabled(Tty(), {})  # type: ignore[arg-type]
    assert not enabled(Tty(), {"CI": "true"})  # type: ignore[arg-type]
    assert not enabled(Tty(), {"NO_COLOR": "1"})  # type: ignore[arg-type]
    assert not enabled(Tty(), {"TERM": "dumb"})  # type: ignore[arg-type]
    assert not enabled(open(os.devnull, "w"), {})


# ---------------------------------------------------------------- pictures of plans

def test_plan_picture_annotates_created_degraded_removed() -> None:
    result = CliRunner().invoke(main, ["graph-plan", BY_NAME["chatter"].file, BY_NAME["redundant"].file])
    assert result.exit_code == 0, result.stderr
    dot = result.stdout
    assert dot.count("digraph ") == 1
    assert '"c:talker" [label="talker", shape=ellipse, fillcolor="#ff6961"' in dot          # removed: red
    assert '"c:mapper" [label="mapper\\n↓ map: steps 7–8", shape=ellipse, fillcolor="#90ee90"' in dot  # created
    assert 'style=dashed, color="#9b1c1c"' in dot


def test_plan_pictures_per_step(tmp_path) -> None:
    args = ["graph-plan", BY_NAME["chatter"].file, BY_NAME["redundant"].file, "--steps"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0
    steps = result.stdout.count("digraph ")
    assert steps > 1 and '"step 1/' in result.stdout
    out = tmp_path / "plan.dot"
    assert CliRunner().invoke(main, args + ["-o", str(out)]).exit_code == 0
    assert len(list(tmp_path.glob("plan-*.dot"))) == steps
    md = CliRunner().invoke(main, args + ["--format", "markdown"]).stdout
    assert md.count("```mermaid") == steps and "**step 1/" in md


def test_degraded_is_orange_in_a_step() -> None:
    from checker.planning import plan_migrate
    from checker.reports.pictures import step_pictures
    from reconf_dsl.loader import load
    p = plan_migrate(load([BY_NAME["chatter"].file]), load([BY_NAME["redundant"].file]))
    degraded = [[(n.label, n.tooltip) for n in pic.nodes if n.status == "degraded"] for pic in step_pictures(p)]
    assert [(i, d) for i, d in enumerate(degraded) if d] == [(7, [("mapper", "degraded: map")]),
                                                             (10, [("listener", "degraded: listen")]),
                                                             (11, [("listener", "degraded: listen")])]


def test_svg_or_a_clear_message(monkeypatch) -> None:
    import shutil
    if shutil.which("dot"):
        result = CliRunner().invoke(main, ["graph", BY_NAME["chatter"].file, "--format", "svg"])
        assert result.exit_code == 0 and "<svg" in result.stdout
    monkeypatch.setenv("PATH", "")
    result = CliRunner().invoke(main, ["graph", BY_NAME["chatter"].file, "--format", "svg"])
    assert result.exit_code == 2
    assert "Graphviz `dot` is not installed" in result.stderr and "--format dot" in result.stderr
