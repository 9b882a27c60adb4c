"""Plans as partial orders (checker/planning/batches.py, docs/soundness.md#batches): a batch runs
only when every order in which its steps can complete keeps every state valid, judged by the
Python engine and by Alloy on their own; an unsafe batch, planted, is refused by each."""
from __future__ import annotations

import json
import os
from dataclasses import replace as dc_replace
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from checker.alloy.engines import Engine
from checker.cli.main import main
from checker.ftm.transition import parse_ftm, plan_transition, with_ftm
from checker.gate.plan_verify import verify_plan
from checker.planning import plan_replace
from checker.planning.alloy_verify import alloy_batches
from checker.planning.batches import BATCH_MAX, Lattice, batch_plan, batch_refusal, moves
from checker.planning.durations import Durations, schedule
from checker.planning.verified import plan_verified
from checker.reports.plan_reader import read_plan
from reconf_dsl.loader import load
from tests.examples_table import ROOT

EXAMPLES = os.path.join(ROOT, "examples")
CHATTER = os.path.join(EXAMPLES, "chatter.arch")
PBR = os.path.join(EXAMPLES, "ftm", "deterministic_pbr.arch")


def _transition() -> Any:
    return plan_transition(load([PBR]), "server", "LFR").plan


def _batched() -> Any:
    """The transition's plan as `reconf plan` makes it: its steps in the order they run, batched."""
    return plan_verified(_transition, use_alloy=False, chain=False).plan


def test_a_batch_of_k_steps_has_every_order_judged() -> None:
    """k·2^(k-1) moves, each from a subset without the step to the subset with it."""
    for k in range(1, BATCH_MAX + 1):
        got = list(moves(k))
        assert len(got) == k * 2 ** (k - 1) == len(set(got))
        assert all(not m & (1 << j) for m, j in got)


def test_the_ftm_transition_runs_its_independent_steps_together() -> None:
    plan = _batched()
    found = plan.batches
    assert found and all(2 <= b - a + 1 <= BATCH_MAX for a, b in found)
    assert batch_plan(plan, move=False) == (plan.steps, found)      # its order is the one that runs
    creates = [i for i, a in enumerate(plan.steps, 1) if a.kind == "create"]
    # a service is kept serving: its creates start one at a time (their CPU is the service's)
    assert all(sum(a <= c <= b for c in creates) <= 1 for a, b in found)
    for a, b in found:
        assert batch_refusal(plan, a, b) == ""
        assert len({s.component for s in plan.steps[a - 1:b]}) == b - a + 1


@pytest.mark.alloy
def test_alloy_agrees_on_every_batch_of_the_transition() -> None:
    plan = _batched()
    found = plan.batches
    judged = alloy_batches(plan, found)
    assert judged["refused"] == {} and judged["batches"] == len(found)
    assert judged["moves"] == sum((b - a + 1) * 2 ** (b - a) for a, b in found)


def test_an_unsafe_batch_is_refused_by_the_python_engine() -> None:
    """Replacing chatter's talker: attaching talker_v2 and detaching talker together may leave
    /chatter without a publisher (the detach first): the listener's assumption fails."""
    plan = plan_replace(load([CHATTER]), "talker", "talker_v2")
    kinds = [a.kind for a in plan.steps]
    at = kinds.index("attach") + 1
    assert kinds[at] == "detach"
    why = batch_refusal(plan, at, at + 1)
    assert "in some order" in why and "detach talker.out from /chatter" in why
    assert "acted on twice" in batch_refusal(plan, at + 1, at + 2)     # the detach and the remove of talker
    assert batch_plan(plan) == (plan.steps, [])


@pytest.mark.alloy
def test_an_unsafe_batch_is_refused_by_alloy_alone() -> None:
    plan = plan_replace(load([CHATTER]), "talker", "talker_v2")
    at = [a.kind for a in plan.steps].index("attach") + 1
    judged = alloy_batches(plan, [(at, at + 1)])
    assert list(judged["refused"]) == [f"{at}-{at + 1}"]
    assert "valid" in judged["refused"][f"{at}-{at + 1}"] or "instance" in judged["refused"][f"{at}-{at + 1}"]


def test_a_lattice_refuses_a_step_without_changing() -> None:
    plan = plan_replace(load([CHATTER]), "talker", "talker_v2")
    at = [a.kind for a in plan.steps].index("attach")
    lat = Lattice.of(plan, plan.states[at])
    assert lat.add(plan.steps[at])
    before = dict(lat.states)
    assert not lat.add(plan.steps[at + 1]) and lat.why
    assert lat.states == before and len(lat.steps) == 1


def test_a_batch_takes_as_long_as_its_slowest_step() -> None:
    plan = _batched()
    times = plan.durations()
    spans, total = schedule(plan.steps, times, plan.batches)
    one_by_one = sum(times.of(a) for a in plan.steps)
    assert total < one_by_one
    a, b = plan.batches[0]
    assert {s for s, _ in spans[a - 1:b]} == {spans[a - 1][0]}
    assert spans[b][0] == pytest.approx(max(e for _, e in spans[a - 1:b]))
    flat = Durations({k: 1.0 for k in times.kinds}, {}, ("test",))
    assert schedule(plan.steps[:3], flat, [(1, 3)])[1] == 1.0 and schedule(plan.steps[:3], flat)[1] == 3.0


def test_the_paper_strategy_runs_one_step_at_a_time() -> None:
    system = with_ftm(load([PBR]), "server", parse_ftm("PBR"))
    verified = plan_verified(lambda: plan_transition(system, "server", "LFR").plan, use_alloy=False, chain=False)
    assert verified.plan.batches and verified.evidence["python"]["batches"] == len(verified.plan.batches)
    assert verified.plan.disruption <= plan_transition(system, "server", "LFR").plan.disruption
    assert verified.plan.to_dict()["batches"] == [list(b) for b in verified.plan.batches]
    paper = plan_verified(lambda: plan_replace(load([CHATTER]), "talker", "talker_v2", strategy="paper"),
                          use_alloy=False, chain=False)
    assert paper.plan.batches == [] and "batches" not in paper.plan.to_dict()


def invoke(*argv: str) -> Any:
    r = CliRunner().invoke(main, list(argv))
    assert "Traceback" not in r.stdout + r.stderr and (r.exception is None or isinstance(r.exception, SystemExit))
    return r


@pytest.mark.alloy
def test_plan_verify_judges_a_documents_batches(tmp_path: Path) -> None:
    """A planted batch in a plan reconf made: refused by both engines (RC310 at the batch) when
    unsafe; a safe one (an FTM transition's own) verified by both."""
    made = invoke("plan", "replace", "talker", "-f", CHATTER, "--output-format", "json")
    doc = json.loads(made.stdout)
    kinds = [s["action"] for s in doc["plan"]["steps"]]
    at = kinds.index("attach") + 1
    doc["plan"]["batches"] = [[at, at + 1]]
    (tmp_path / "p.json").write_text(json.dumps(doc, indent=1), encoding="utf-8")
    for engine in ("python", "alloy"):
        r = invoke("plan", "verify", str(tmp_path / "p.json"), "-f", CHATTER, "--engine", engine,
                   "--output-format", "json")
        assert r.exit_code == 1, (engine, r.stdout)
        out = json.loads(r.stdout)
        assert not out["engines"][engine]["valid"]
        if engine == "python":
            (d,) = out["diagnostics"]
            assert d["code"] == "RC310" and f"steps {at}–{at + 1}" in d["message"]
    plan = _batched()
    text = json.dumps({"plan": plan.to_dict()})
    judged = verify_plan(plan.system, read_plan("t.json", text, plan.system), Engine.BOTH)
    assert judged.safe, judged.engines
    assert judged.engines["alloy"]["batches"]["refused"] == {}
    assert judged.engines["alloy"]["batches"]["batches"] == len(plan.batches)


def test_a_batch_that_is_not_a_run_of_steps_is_a_bad_document(tmp_path: Path) -> None:
    made = invoke("plan", "replace", "talker", "-f", CHATTER, "--output-format", "json")
    doc = json.loads(made.stdout)
    doc["plan"]["batches"] = [[3, 3]]
    (tmp_path / "p.json").write_text(json.dumps(doc, indent=1), encoding="utf-8")
    r = invoke("plan", "verify", str(tmp_path / "p.json"), "-f", CHATTER, "--engine", "python")
    assert r.exit_code == 2 and "RC308" in r.stderr and "batch 1 (3–3)" in r.stderr


def test_batches_never_cost_seconds_nor_relink_while_a_protocol_is_suspended() -> None:
    """The plan's degraded seconds with its batches are no more than one step at a time; a
    protocol's suspension or resumption runs beside mode changes only; and a moved step is a
    re-linking one, the modes changed in the order the plan chose."""
    plan, before = _batched(), _transition()
    alone = dc_replace(plan, batches=[])
    assert plan.seconds().weighted <= alone.seconds().weighted and plan.seconds().total < alone.seconds().total
    protocols = {p for _, p in plan.protocols}
    for a, b in plan.batches:
        kinds = {s.kind for s in plan.steps[a - 1:b]}
        if any(s.kind in ("degrade", "upgrade") and s.component in protocols for s in plan.steps[a - 1:b]):
            assert kinds <= {"degrade", "upgrade"}, (a, b)
    modes = [s for s in before.steps if s.kind in ("degrade", "upgrade", "create")]
    assert [s for s in plan.steps if s.kind in ("degrade", "upgrade", "create")] == modes
    assert sorted(map(repr, plan.steps)) == sorted(map(repr, before.steps))
