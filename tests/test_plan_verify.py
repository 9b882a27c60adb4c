"""`reconf plan verify PLAN.json -f ARCH`: any plan document, in both engines, each on its own.

A plan reconf made is verified in either format; a hand-made plan that breaks any rule of
checker.semantic_model.rules (each witness of tests/test_rules.py, written as a document) is refused by
the Python engine alone and by Alloy alone; the first rule broken is located in the JSON; text
that is not a plan document is bad input (exit 2), never a traceback."""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from checker.alloy.engines import Engine
from checker.cli.main import main
from checker.gate.plan_verify import verify_plan
from checker.planning.plan import state_dict
from checker.reports.plan_reader import read_plan
from checker.semantic_model.actions import effect
from checker.semantic_model.config import Configuration
from reconf_dsl.diagnostics import DiagnosticError
from tests.examples_table import ROOT
from tests.test_rules import all_witnesses

EXAMPLES = os.path.join(ROOT, "examples")
CHATTER = os.path.join(EXAMPLES, "chatter.arch")
PLANS = os.path.join(EXAMPLES, "plans")


def invoke(*argv: str) -> Any:
    r = CliRunner().invoke(main, list(argv))
    assert "Traceback" not in r.stdout + r.stderr and (r.exception is None or isinstance(r.exception, SystemExit))
    return r


def _single(tmp_path: Path) -> str:
    """chatter with /chatter declared `single`."""
    text = Path(CHATTER).read_text(encoding="utf-8").replace("topic /chatter: String @ 10 Hz {",
                                                             "topic /chatter: String @ 10 Hz single {")
    out = tmp_path / "chatter_single.arch"
    out.write_text(text, encoding="utf-8")
    return str(out)


@pytest.mark.alloy
def test_a_plan_reconf_made_is_verified_in_both_formats(tmp_path: Path) -> None:
    made = invoke("plan", "replace", "talker", "-f", CHATTER, "--output-format", "json")
    assert made.exit_code == 0
    (tmp_path / "plan.json").write_text(made.stdout, encoding="utf-8")
    for plan in (str(tmp_path / "plan.json"), os.path.join(PLANS, "replace_talker.json")):
        r = invoke("plan", "verify", plan, "-f", CHATTER, "--output-format", "json")
        assert r.exit_code == 0, r.stderr
        doc = json.loads(r.stdout)
        assert doc["verdict"] == "safe" and doc["engines"]["python"]["valid"] and doc["engines"]["alloy"]["valid"]


@pytest.mark.alloy
def test_make_before_break_on_a_single_topic_is_refused_by_both(tmp_path: Path) -> None:
    """Two publishers on a `single` topic in the third state: the rule is named, at its step."""
    single = _single(tmp_path)
    r = invoke("plan", "verify", os.path.join(PLANS, "replace_talker.json"), "-f", single, "--output-format", "json")
    assert r.exit_code == 1, r.stderr
    doc = json.loads(r.stdout)
    (d,) = doc["diagnostics"]
    assert d["code"] == "RC304" and "attach.single" in d["message"] and "step 3" in d["message"]
    assert d["span"]["file"].endswith("replace_talker.json") and d["span"]["line"] == 7
    alloy = doc["engines"]["alloy"]
    assert not alloy["valid"] and alloy["reason"].startswith("step 3 (attach talker_v2.out to /chatter)")


@pytest.mark.alloy
def test_the_readme_plan_is_refused_where_it_breaks_the_rule() -> None:
    r = invoke("plan", "verify", os.path.join(PLANS, "break_before_make.json"), "-f", CHATTER)
    assert r.exit_code == 1
    assert "break_before_make.json:5:7: error[RC304]: step 1 (detach talker.out from /chatter) breaks detach.output" \
        in r.stderr


def _document(before: Configuration, steps: list[Any], states: list[Configuration]) -> str:
    return json.dumps({"format_version": 1, "plan": {"steps": [a.to_dict() for a in steps],
                                                     "states": [state_dict(s) for s in [before, *states]]}}, indent=1)


@pytest.mark.alloy
@pytest.mark.parametrize("engine", [Engine.PYTHON, Engine.ALLOY])
def test_a_plan_that_breaks_any_rule_is_refused_by_each_engine_alone(engine: Engine) -> None:
    for system, w in all_witnesses():
        if w.action is None:
            text = _document(w.before, [], [])
        else:
            after = w.after if w.after is not None else effect(system, w.before, w.action)
            text = _document(w.before, [w.action], [after])
        judged = verify_plan(system, read_plan("plan.json", text, system), engine)
        assert not judged.safe, (engine, w.rule)
        if engine is Engine.PYTHON:     # the witness's rule, or one its (ill-formed) first state breaks first
            message = judged.diagnostics[0].message
            assert f"breaks {w.rule}:" in message or "the first configuration breaks state." in message, w.rule


@pytest.mark.alloy
def test_a_change_no_step_names_is_refused_by_alloy_alone(tmp_path: Path) -> None:
    """A format 1 state that also drops an attachment no step touches: Alloy's slice of the
    plan takes in every component that changes, named by a step or not."""
    doc = json.loads(Path(PLANS, "replace_talker.json").read_text(encoding="utf-8"))
    doc["plan"]["states"][1]["roles"] = [r for r in doc["plan"]["states"][1]["roles"] if r[1] != "listener"]
    for s in doc["plan"]["states"][2:]:
        s["roles"] = [r for r in s["roles"] if r[1] != "listener"]
    (tmp_path / "p.json").write_text(json.dumps(doc), encoding="utf-8")
    for engine in ("python", "alloy"):
        r = invoke("plan", "verify", str(tmp_path / "p.json"), "-f", CHATTER, "--engine", engine,
                   "--output-format", "json")
        assert r.exit_code == 1, (engine, r.stdout)


@pytest.mark.parametrize("text, code, where, said", [
    ("{\n  \"plan\": [1,\n", "RC308", (3, 1), "not a plan document"),
    ("[]", "RC308", (1, 1), "a plan document is a JSON object"),
    ('{"plan": {"steps": [{"action": "jump", "component": "talker"}], "start": {}, "changes": [{}]}}',
     "RC308", (1, 32), "unknown action 'jump'"),
    ('{"plan": {"steps": [], "start": {"components": ["talker", 3]}, "changes": []}}', "RC308", (1, 59),
     "an entry of `components`"),
    ('{"plan": {"steps": [{"action": "remove", "component": "talkr"}], "start": {}, "changes": [{}]}}',
     "RC309", (1, 21), "no component talkr is declared"),
    ('{"plan": {"steps": [], "start": {"roles": [["/chatter", "talker", "in"]]}, "changes": []}}', "RC309",
     (1, 44), "talker has no port in"),
    ('{"plan": {"steps": [{"action": "create", "component": "talker"}], "start": {}, "changes": []}}', "RC308",
     (1, 91), "1 step needs 1 change, not 0"),
    ('{"format_version": 7, "plan": {}}', "RC308", (1, 20), "format 7 is not 1 or 2"),
])
def test_what_is_not_a_plan_document_is_bad_input(tmp_path: Path, text: str, code: str, where: tuple[int, int],
                                                   said: str) -> None:
    plan = tmp_path / "p.json"
    plan.write_text(text, encoding="utf-8")
    r = invoke("plan", "verify", str(plan), "-f", CHATTER, "--engine", "python", "--output-format", "json")
    assert r.exit_code == 2, r.stdout
    (d,) = json.loads(r.stdout)["diagnostics"]
    assert d["code"] == code and said in d["message"], d
    assert (d["span"]["line"], d["span"]["column"]) == where, d


def test_the_reader_refuses_without_a_system_loaded() -> None:
    from reconf_dsl.loader import load
    with pytest.raises(DiagnosticError):
        read_plan("p.json", "nope", load([CHATTER]))
