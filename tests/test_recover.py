"""Recovery from any observed configuration (docs/executor.md#failure-and-recovery): validity is
restored first, by the least set of degrades, readers first, a prefix whose property is proved
(docs/soundness.md#restoring-validity) and checked on each plan; then the plan goes on to the
target or back to the start, verified as any plan; a recovery with nothing to do says so and
exits 0; `--live` plans from a snapshot of the running system, orphans of a plan included."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.planning import plan_replace
from checker.planning.plan import NoSafePlan, state_dict
from checker.planning.recovery import check_restore, plan_recovery, restore_validity
from checker.reports.plan_document import plan_document
from checker.semantic_model import unbounded
from checker.semantic_model.actions import Degrade, is_valid
from checker.semantic_model.config import Configuration
from reconf_dsl.loader import load
from reconf_ros.executor.snapshot import NodeInfo, Snapshot
from tests.examples_table import ROOT

CHATTER = os.path.join(ROOT, "examples", "chatter.arch")
CHAIN = os.path.join(ROOT, "examples", "chain5.arch")


def without(config: Configuration, comp: str) -> Configuration:
    """`config` with `comp` gone (its node died): its modes and attachments with it."""
    return Configuration(config.components - {comp}, frozenset(d for d in config.degraded if d[0] != comp),
                         frozenset(r for r in config.roles if r[1] != comp))


def test_the_prefix_is_the_least_set_readers_first() -> None:
    system = load([CHAIN])
    seen = without(Configuration.initial(system), "stage0")
    prefix = restore_validity(system, seen)
    assert prefix == [Degrade(f"stage{i}", "step") for i in (4, 3, 2, 1)]
    end = check_restore(system, seen, prefix)
    assert is_valid(system, end)
    # any other order is sound too (RecoverMonotone); one degrade too few is not
    check_restore(system, seen, list(reversed(prefix)))
    with pytest.raises(NoSafePlan, match="no later step degrades it"):
        check_restore(system, seen, prefix[1:])
    with pytest.raises(NoSafePlan, match="after 0 degrades, stage1.step still fails"):
        check_restore(system, seen, [])


def test_a_valid_observed_configuration_needs_no_prefix() -> None:
    system = load([CHAIN])
    start = Configuration.initial(system)
    assert restore_validity(system, start) == []
    plan = plan_recovery(system, start, start)
    assert plan.steps == [] and plan.recovery is not None and plan.recovery.restore == 0


def test_the_plan_goes_on_to_the_target_from_the_prefix_end() -> None:
    system = load([CHAIN])
    target = Configuration.initial(system)
    plan = plan_recovery(system, without(target, "stage0"), target)
    assert plan.recovery is not None and plan.recovery.restore == 4
    assert [a.kind for a in plan.steps[:4]] == ["degrade"] * 4
    assert plan.states[-1] == target
    assert plan.recovery.rest is not None and plan.recovery.rest.steps == plan.steps[4:]
    assert all(is_valid(system, s) for s in plan.states[4:]) and not is_valid(system, plan.states[0])
    assert plan.to_dict()["recovery"] == {"restore": 4, "placed": {}, "orphans": []}


@pytest.mark.parametrize("assertion", unbounded.RECOVERY_ASSERTIONS)
def test_the_prefix_property_is_proved_for_every_size(assertion: str) -> None:
    assert unbounded.prove(assertion).result == "proved"


def test_rule_iii_is_what_makes_degrading_monotone() -> None:
    proof = unbounded.prove("RecoverMonotone", ["modes.rule_iii"])
    assert proof.result == "counterexample" and proof.counterexample is not None


def test_degrading_can_break_a_reader() -> None:
    """RecoverDegrade's case of a reader newly failing is not vacuous."""
    assert unbounded.recovery_breaks_a_reader() == "sat"


# --- the command, from a report ----------------------------------------------------------

def report(tmp_path: Path, observed: Any, name: str = "failed.json") -> str:
    system = load([CHATTER])
    plan = plan_replace(system, "talker", "talker_v2")
    doc = plan_document("replace talker", system, plan, {"python": {}}, model=True)
    seen = observed(plan.states)
    path = tmp_path / name
    path.write_text(json.dumps({"kind": "run-report", "observed": state_dict(seen), "plan_document": doc}))
    return str(path)


def invoke(argv: list[str]) -> Any:
    return CliRunner().invoke(main, argv)


@pytest.mark.alloy
def test_recover_degrades_what_fails_then_goes_on_verified_by_alloy(tmp_path: Path) -> None:
    """talker died after talker_v2 was created: the listener fails; it is degraded first, and
    Alloy verifies the plan from there (before, Alloy refuted it: the first state is not valid)."""
    path = report(tmp_path, lambda states: without(states[1], "talker"))
    r = invoke(["recover", path, "-o", str(tmp_path / "recover.py")])
    assert r.exit_code == 0, r.stderr
    text = " ".join(r.stderr.split())
    assert "1. ↓ degrade listener.listen" in text and "4. ↑ upgrade listener.listen" in text
    assert "step 1 degrades what fails" in text and "Alloy: 4 states valid" in text, text
    dry = subprocess.run([sys.executable, str(tmp_path / "recover.py"), "--dry-run"], capture_output=True, text=True)
    assert dry.returncode == 0, dry.stdout + dry.stderr
    assert "[restoring]" in dry.stdout and "step 1 restores validity; the 4 states from there are safe" in dry.stdout


def test_a_recovery_with_nothing_to_do_says_so_and_exits_0(tmp_path: Path) -> None:
    path = report(tmp_path, lambda states: states[-1], "violated.json")
    script = tmp_path / "recover.py"
    r = invoke(["recover", path, "--no-alloy", "-o", str(script)])
    assert r.exit_code == 0, r.stderr
    assert "nothing to recover: the observed configuration is valid and is the target" in " ".join(r.stderr.split())
    done = subprocess.run([sys.executable, str(script), "--yes"], capture_output=True, text=True)
    assert done.returncode == 0 and "nothing to do: the plan has no step" in done.stdout, done.stdout + done.stderr


def test_recover_applies_with_the_script_options(tmp_path: Path) -> None:
    """Without -o the plan is carried out by the executor (here --dry-run: the replay alone)."""
    path = report(tmp_path, lambda states: without(states[1], "talker"))
    r = invoke(["recover", path, "--back", "--no-alloy", "--dry-run"])
    assert r.exit_code == 0, r.stderr
    assert "remove talker_v2" in r.stderr and "[restoring]" in r.stderr and "restores validity" in r.stderr


@pytest.mark.parametrize("argv, said", [
    (["recover"], "give either a run REPORT or --live"),
    (["recover", CHATTER, "--live"], "give either a run REPORT or --live"),
    (["recover", "--live", "--back", "-f", CHATTER], "--back goes with a REPORT"),
])
def test_recover_usage(argv: list[str], said: str) -> None:
    r = invoke(argv)
    assert r.exit_code == 2 and said in r.stderr, r.stderr


# --- the command, from the live system (a snapshot) ----------------------------------------

def node(fqn: str, comp: str, lifecycle: str = "active", modes: Any = None, ports: Any = None,
         created: Any = None, pid: Any = None) -> NodeInfo:
    """A reconf node as a snapshot shows it (its model: the component's, as `--describe` prints it)."""
    return NodeInfo(fqn, lifecycle=lifecycle, model=_model(comp), component=comp, modes=modes or {},
                    ports=ports or {}, created=created, pid=pid)


def _model(comp: str) -> str:
    return {"talker": _TALKER, "talker_v2": _TALKER.replace("talker", "talker_v2"), "listener": _LISTENER}[comp]


_TALKER = ("message String = std_msgs/msg/String\n\ncomponent talker {\n  output out: String\n\n"
           "  functionality talk (out) {\n    normal { out: String @ 10 Hz }\n    degraded { out: nothing }\n  }\n}\n")
_LISTENER = ("message String = std_msgs/msg/String\n\ncomponent listener {\n  input in: String @ 10 Hz\n\n"
             "  functionality listen (in) {\n    normal { assume String @ 10 Hz }\n    degraded { }\n  }\n}\n")


def test_live_talker_crashed_and_an_orphan_left(tmp_path: Path) -> None:
    """A plan script killed while it started talker_v2 (unconfigured, marked), and the talker
    crashed: the orphan is ended first, the listener degraded, the talker started again."""
    snap = Snapshot(nodes={
        "/listener": node("/listener", "listener", modes={"listen": "normal"}, ports={"in": ["/chatter"]}),
        "/talker_v2": node("/talker_v2", "talker_v2", lifecycle="inactive", created="sha256:x talker_v2", pid=4242),
    }, topics={"/chatter": ["std_msgs/msg/String"]})
    path = tmp_path / "snap.json"
    path.write_text(snap.to_json())
    script = tmp_path / "recover.py"
    r = invoke(["recover", "--live", "-f", CHATTER, "--snapshot", str(path), "--no-alloy", "-o", str(script)])
    assert r.exit_code == 0, r.stderr
    text = " ".join(r.stderr.split())
    assert "orphan: /talker_v2 (pid 4242)" in text
    for line in ("1. ↓ degrade listener.listen", "2. + create talker", "5. ↑ upgrade listener.listen"):
        assert line in text, text
    doc = json.loads(script.read_text().split('DOC = json.loads(r"""', 1)[1].split('"""', 1)[0])
    recovery = doc["plan"]["recovery"]
    assert recovery["restore"] == 1 and [o["node"] for o in recovery["orphans"]] == ["/talker_v2"]


def test_live_an_active_orphan_is_taken_away(tmp_path: Path) -> None:
    """talker_v2 created, upgraded and attached by a plan whose script died: the model's
    deployed configuration has no talker_v2, so the recovery detaches, degrades and removes it."""
    snap = Snapshot(nodes={
        "/talker": node("/talker", "talker", modes={"talk": "normal"}, ports={"out": ["/chatter"]}),
        "/listener": node("/listener", "listener", modes={"listen": "normal"}, ports={"in": ["/chatter"]}),
        "/talker_v2": node("/talker_v2", "talker_v2", modes={"talk": "normal"}, ports={"out": ["/chatter"]},
                           created="sha256:x talker_v2"),
    }, topics={"/chatter": ["std_msgs/msg/String"]})
    path = tmp_path / "snap.json"
    path.write_text(snap.to_json())
    r = invoke(["recover", "--live", "-f", CHATTER, "--snapshot", str(path), "--no-alloy", "--dry-run"])
    assert r.exit_code == 0, r.stderr
    text = " ".join(r.stderr.split())
    assert "detach talker_v2.out from /chatter" in text and "remove talker_v2" in text, text


def test_live_a_node_that_does_not_answer_is_2(tmp_path: Path) -> None:
    snap = Snapshot(nodes={
        "/talker": replace(node("/talker", "talker"), unanswered="get_state: no answer"),
        "/listener": node("/listener", "listener", modes={"listen": "normal"}, ports={"in": ["/chatter"]}),
    })
    path = tmp_path / "snap.json"
    path.write_text(snap.to_json())
    r = invoke(["recover", "--live", "-f", CHATTER, "--snapshot", str(path), "--no-alloy", "--dry-run"])
    assert r.exit_code == 2 and "RC632" in r.stderr and "does not answer" in r.stderr, r.stderr


def test_live_an_orphan_no_component_accounts_for_joins_the_model(tmp_path: Path) -> None:
    """A new version a migration started as /talker_2 (it declares talker, as /talker does), on a
    topic the model does not have: it is read from its own model, under its node's name, and
    taken away; the topic becomes a connector of its type."""
    snap = Snapshot(nodes={
        "/talker": node("/talker", "talker", modes={"talk": "normal"}, ports={"out": ["/chatter"]}),
        "/listener": node("/listener", "listener", modes={"listen": "normal"}, ports={"in": ["/chatter"]}),
        "/talker_2": node("/talker_2", "talker", modes={"talk": "normal"}, ports={"out": ["/chatter2"]},
                          created="sha256:x talker@new", pid=99),
    }, topics={"/chatter": ["std_msgs/msg/String"], "/chatter2": ["std_msgs/msg/String"]})
    path = tmp_path / "snap.json"
    path.write_text(snap.to_json())
    script = tmp_path / "recover.py"
    r = invoke(["recover", "--live", "-f", CHATTER, "--snapshot", str(path), "--no-alloy", "-o", str(script)])
    assert r.exit_code == 0, r.stderr
    text = " ".join(r.stderr.split())
    assert "detach talker_2.out from /chatter2" in text and "remove talker_2" in text, text
    doc = json.loads(script.read_text().split('DOC = json.loads(r"""', 1)[1].split('"""', 1)[0])
    assert doc["plan"]["recovery"]["placed"] == {"talker_2": "talker_2"}
    assert any(k["name"] == "/chatter2" for k in doc["model"]["connectors"])


def test_live_another_definition_under_a_components_name_is_replaced_by_the_models(tmp_path: Path) -> None:
    """A transition killed before it created the new version left /talker running the old
    definition (here with a second output, /debug): it is talker as it runs; the model's talker
    is created beside it as talker@new (the executor gives it a free node name) and takes over,
    and the old one is taken away, verified in both engines."""
    old = _TALKER.replace("  output out: String\n", "  output out: String\n  output debug: String\n") \
        .replace("functionality talk (out)", "functionality talk (out, debug)") \
        .replace("normal { out: String @ 10 Hz }", "normal { out: String @ 10 Hz  debug: String @ 1 Hz }") \
        .replace("degraded { out: nothing }", "degraded { out: nothing  debug: nothing }")
    snap = Snapshot(nodes={
        "/talker": replace(node("/talker", "talker", modes={"talk": "normal"},
                                ports={"out": ["/chatter"], "debug": ["/debug"]}), model=old),
        "/listener": node("/listener", "listener", modes={"listen": "normal"}, ports={"in": ["/chatter"]}),
    }, topics={"/chatter": ["std_msgs/msg/String"], "/debug": ["std_msgs/msg/String"]})
    path = tmp_path / "snap.json"
    path.write_text(snap.to_json())
    script = tmp_path / "recover.py"
    r = invoke(["recover", "--live", "-f", CHATTER, "--snapshot", str(path), "-o", str(script)])
    assert r.exit_code == 0, r.stderr
    text = " ".join(r.stderr.split())
    assert "RC633" in text and "created beside it as talker@new" in text, text
    assert "+ create talker@new" in text and "- remove talker" in text and "✓ Alloy" in text, text
    doc = json.loads(script.read_text().split('DOC = json.loads(r"""', 1)[1].split('"""', 1)[0])
    assert doc["plan"]["renames"] == {"talker@new": "talker"}
    assert [s["component"] for s in doc["plan"]["steps"] if s["action"] in ("create", "remove")] == ["talker@new", "talker"]


def test_a_start_that_is_not_well_formed_is_refused_by_the_python_engine_alone() -> None:
    """A configuration read from a live system can break a rule no step would (here an output
    attached while its component is absent): the Python engine's verification refuses it before
    any step, as Alloy's does."""
    from checker.planning.plan import Goal, verify
    system = load([CHATTER])
    start = Configuration.initial(system)
    broken = Configuration(start.components - {"talker"}, frozenset(d for d in start.degraded if d[0] != "talker"),
                           start.roles)
    with pytest.raises(NoSafePlan, match="not well formed: talker.out is attached to /chatter, but talker is not"):
        verify(system, broken, [], Goal(broken.components, broken.roles, broken.degraded), "default")


def test_a_node_s_message_types_keep_their_names_where_several_share_a_ros_type() -> None:
    """An FTM's messages are all std_msgs/msg/String under several names: an adopted
    definition's ports keep the names the model gives them, not the last name of that type."""
    from checker.reality.observed import _adopted
    from reconf_dsl.ir import MessageType
    from reconf_dsl.parser import parse_text
    system = load([CHATTER])
    system = replace(system, messages=system.messages + (MessageType("Other", "std_msgs/msg/String"),))
    doc = parse_text(_TALKER, "<m>")
    comp = next(it for it in doc.items if getattr(it, "ports", None))
    _, adopted = _adopted(system, doc.items, replace(comp, name="talker_2"))
    assert [p.message for p in adopted.ports] == ["String"]
