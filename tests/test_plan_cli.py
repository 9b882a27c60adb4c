"""`reconf plan ...` end to end on the shared examples (Python verification; Alloy in tests/alloy)."""
from __future__ import annotations

import json
import os

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from tests.examples_table import BY_NAME, EXAMPLES
from tests.support.ftm import assert_prepared_first_cleaned_up_last

CHATTER = BY_NAME["chatter"].file


def invoke(*args: str) -> "object":
    return CliRunner().invoke(main, list(args))


def test_paper_strategy_reproduces_the_seven_steps() -> None:
    r = invoke("plan", "replace", "talker", "-f", CHATTER, "--strategy", "paper", "--no-alloy",
               "--output-format", "json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    from checker.semantic_model.actions import action_from_dict
    steps = tuple(action_from_dict(s).describe() for s in doc["plan"]["steps"])
    assert steps == BY_NAME["chatter"].paper_plan
    assert doc["format_version"] == 2 and doc["fingerprint"].startswith("sha256:")
    assert doc["evidence"]["python"]["valid"] is True


def test_every_example_with_a_version_has_a_paper_plan_in_the_table() -> None:
    for ex in EXAMPLES:
        if ex.replace:
            r = invoke("plan", "replace", ex.replace, "-f", ex.file, "--strategy", "paper", "--no-alloy")
            assert r.exit_code == 0
            for i, step in enumerate(ex.paper_plan, 1):
                assert f"{i:>3}. " in r.stderr and step in r.stderr


def test_text_output_like_terraform() -> None:
    r = invoke("plan", "replace", "talker", "-f", CHATTER, "--no-alloy")
    assert r.exit_code == 0
    text = r.stderr
    assert "reconf will replace talker with talker_v2 in 5 steps (strategy default):" in text
    assert "1. + create talker_v2 (all functionalities degraded)" in text
    assert "Plan: 5 actions" in text and "Disruption: 1" in text
    assert "✓ Python engine: every precondition holds, all 6 states valid" in text


def test_default_is_less_disruptive_than_paper_on_chatter() -> None:
    docs = {}
    for strategy in ("paper", "default", "exhaustive"):
        r = invoke("plan", "replace", "talker", "-f", CHATTER, "--no-alloy", "--strategy", strategy,
                   "--output-format", "json")
        assert r.exit_code == 0
        docs[strategy] = json.loads(r.stdout)["plan"]["disruption"]
    assert docs["default"] <= docs["paper"]
    assert docs["default"] == docs["exhaustive"]


def test_remove_and_add(tmp_path: "os.PathLike[str]") -> None:
    r = invoke("plan", "remove", "obstacle_detector", "-f", BY_NAME["robot"].file, "--no-alloy",
               "--output-format", "json")
    assert r.exit_code == 0, r.output
    kinds = [s["action"] for s in json.loads(r.stdout)["plan"]["steps"]]
    assert kinds[-1] == "remove" and "degrade" in kinds
    r = invoke("plan", "add", "talker", "--from", CHATTER, "-f", BY_NAME["chatter_unpublished"].file,
               "--no-alloy", "--output-format", "json")
    # the listener is unsafe before the talker arrives: no plan starts from an unsafe configuration
    assert r.exit_code == 1 and "not valid" in json.loads(r.stdout)["reasons"][0]


def test_migrate(tmp_path: "os.PathLike[str]") -> None:
    with open(BY_NAME["robot"].file) as f:
        old = f.read()
    new = old.replace("      out: Obstacles @ 1 Hz", "      out: Obstacles @ 2 Hz")
    d = os.path.dirname(BY_NAME["robot"].file)
    target = os.path.join(d, "common", "..", "robot.arch")
    path = os.path.join(str(tmp_path), "robot_v2.arch")
    os.makedirs(os.path.join(str(tmp_path), "common"), exist_ok=True)
    with open(os.path.join(d, "common", "messages.arch")) as f, \
            open(os.path.join(str(tmp_path), "common", "messages.arch"), "w") as g:
        g.write(f.read())
    with open(path, "w") as f:
        f.write(new)
    r = invoke("plan", "migrate", target, path, "--no-alloy", "--output-format", "json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert [s["action"] for s in doc["plan"]["steps"]] == ["create", "upgrade", "attach", "detach", "remove"]
    assert doc["target_fingerprint"] != doc["fingerprint"]


def test_no_safe_plan_exits_1_and_says_why(tmp_path: "os.PathLike[str]") -> None:
    with open(CHATTER) as f:
        text = f.read()
    slow = text.replace("component talker_v2 replaces talker {", "component talker_v2 replaces talker {  // slow")
    slow = slow.replace("""  functionality talk (out) {
    normal { out: String @ 10 Hz }
    degraded { out: nothing }
  }
}

component listener""", """  functionality talk (out) {
    normal { out: String @ 2 Hz }
    degraded { out: nothing }
  }
}

component listener""")
    path = os.path.join(str(tmp_path), "slow.arch")
    with open(path, "w") as f:
        f.write(slow)
    r = invoke("plan", "replace", "talker", "-f", path, "--no-alloy")
    assert r.exit_code == 1
    assert "no safe plan" in r.stderr and "listener.listen assumes String @ 10 Hz" in r.stderr


def test_missing_version_is_explained() -> None:
    r = invoke("plan", "replace", "listener", "-f", CHATTER, "--no-alloy")
    assert r.exit_code == 2 and "listener has no declared new version" in r.stderr


@pytest.mark.parametrize("args, said", [
    (("replace", "nosuch"), "nosuch is not a deployed component of chatter"),
    (("replace", "talkr"), "talkr is not a deployed component of chatter (did you mean talker?)"),
    (("remove", "listenr"), "listenr is not a deployed component of chatter (did you mean listener?)"),
    (("replace", "talker", "--with", "listener"), "listener is deployed already"),
    (("replace", "talker", "--with", "talker"), "talker cannot replace itself"),
    (("replace", "talker", "--with", "talker_v9"), "talker_v9 is not a declared component of chatter"),
])
def test_a_mistake_in_what_to_plan_is_a_usage_error(args: tuple[str, ...], said: str) -> None:
    """Not "no safe plan" (exit 1), which would say the change is unsafe: the user's words, exit 2."""
    r = invoke("plan", *args, "-f", CHATTER, "--no-alloy", "--output-format", "json")
    assert r.exit_code == 2 and said in r.stderr and "Usage:" in r.stderr and not r.stdout, r.output


def test_detailed_exitcode_tells_a_change_from_nothing_to_do() -> None:
    change = invoke("plan", "replace", "talker", "-f", CHATTER, "--no-alloy", "--detailed-exitcode")
    same = invoke("plan", "migrate", CHATTER, CHATTER, "--no-alloy", "--detailed-exitcode")
    plain = invoke("plan", "replace", "talker", "-f", CHATTER, "--no-alloy")
    assert (change.exit_code, same.exit_code, plain.exit_code) == (3, 0, 0)


@pytest.mark.alloy
def test_alloy_engine_matches_the_optimum() -> None:
    r = invoke("plan", "replace", "talker", "-f", CHATTER, "--engine", "alloy", "--no-alloy", "--output-format", "json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["plan"]["strategy"] == "alloy"
    best = invoke("plan", "replace", "talker", "-f", CHATTER, "--strategy", "exhaustive", "--no-alloy",
                  "--output-format", "json")
    assert doc["plan"]["disruption"] == json.loads(best.stdout)["plan"]["disruption"]


@pytest.mark.alloy
def test_alloy_verification_is_in_the_evidence() -> None:
    r = invoke("plan", "replace", "talker", "-f", CHATTER, "--strategy", "paper", "--output-format", "json")
    assert r.exit_code == 0, r.output
    alloy = json.loads(r.stdout)["evidence"]["alloy"]
    assert alloy["valid"] is True and alloy["states"] == 8 and alloy["transitions"] == 7
    assert alloy["module_hash"].startswith("sha256:")


def test_migrate_between_ftms_plans_on_the_expansions() -> None:
    ftm = os.path.join(os.path.dirname(CHATTER), "ftm")
    r = invoke("plan", "migrate", os.path.join(ftm, "deterministic_pbr.arch"),
               os.path.join(ftm, "deterministic_lfr.arch"), "--no-alloy", "--output-format", "json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    steps = [s for s in doc["plan"]["steps"]]
    touched = {s.get("component", "") for s in steps}
    suspended = [s["component"] for s in steps if s["action"] == "degrade" and s["component"].endswith("_protocol")]
    assert suspended == ["server__r0_dup_protocol", "server__r1_dup_protocol"]   # the protocols are suspended
    assert not any(c.endswith("_proceed") for c in touched)           # the application replicas are kept
    assert_prepared_first_cleaned_up_last(steps)
