"""Disruption in seconds: how long each action takes (measured defaults, `takes` lines, a run
report), a plan's degraded seconds, and the default strategy's order (prepare first, clean up
last) judged by them."""
from __future__ import annotations

import os

import pytest

from checker.ftm.transition import plan_transition
from checker.planning import plan_replace
from checker.planning.durations import Durations, degraded_seconds, durations
from checker.planning.improve import cost
from checker.planning.plan import verify
from checker.planning.prepare import _move, prepare_first
from checker.semantic_model.actions import KINDS, Create, Degrade
from reconf_dsl import ir
from reconf_dsl.loader import load, load_text
from tests.support.systems import talker_system

EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "examples")


def test_the_six_actions_the_language_times_are_the_registry_s() -> None:
    assert ir.ACTIONS == tuple(k.name for k in KINDS)
    assert all(k.seconds > 0 for k in KINDS)
    # the measured defaults: a create (a process start and discovery) is the slow one
    assert max(KINDS, key=lambda k: k.seconds).name == "create"


def test_a_takes_line_overrides_the_default_for_its_component_only() -> None:
    text = open(os.path.join(EXAMPLES, "chatter.arch")).read().replace(
        "  host robot\n  output out: String\n", "  host robot\n  output out: String\n  takes create 2.5 s, upgrade 40 ms\n", 2)
    assert "takes create" in text
    times = durations(load_text(text, "chatter.arch"))
    assert times.components == {(c, a): s for c in ("talker", "talker_v2") for a, s in (("create", 2.5), ("upgrade", 0.04))}
    assert times.of(Create("talker_v2")) == 2.5 and times.of(Create("listener")) == times.kinds["create"]
    assert "takes" in times.sources[-1]


def test_a_run_report_s_timings_override_both() -> None:
    system = talker_system()
    plan = plan_replace(system, "talker", "talker_v2", strategy="paper")
    steps = plan.to_dict()["steps"]
    report = {"plan_document": {"plan": {"steps": steps}},
              "timings": [{"step": i, "ok": True, "seconds": 3.0 if s["action"] == "create" else 0.01}
                          for i, s in enumerate(steps, 1)] + [{"step": 99, "ok": True, "seconds": 50.0}]}
    times = durations(system).observed(report, "run.json")
    assert times.kinds["create"] == 3.0 and times.kinds["degrade"] == 0.01
    assert times.components[("talker_v2", "create")] == 3.0
    assert times.sources[-1] == "run.json (7 steps timed)"
    assert durations(system).observed({"timings": []}, "empty.json") == durations(system)


def test_degraded_seconds_count_what_served_while_each_step_runs() -> None:
    """The paper's plan degrades the listener at step 1 and upgrades it at step 7: it is degraded
    while steps 2..7 run. talker_v2, created degraded, served no one before: it does not count."""
    plan = plan_replace(talker_system(), "talker", "talker_v2", strategy="paper")
    times = durations(plan.system)
    sec = degraded_seconds(plan.system, plan.states[0], plan.steps, times)
    assert set(sec.seconds) == {("listener", "listen")}
    assert sec.seconds[("listener", "listen")] == pytest.approx(sum(times.of(a) for a in plan.steps[1:]))
    assert sec.total == pytest.approx(sum(times.of(a) for a in plan.steps))
    assert plan.seconds() == sec and plan.to_dict()["seconds"]["weighted"] == round(sec.weighted, 3)


def test_criticality_weighs_the_seconds() -> None:
    plan = plan_replace(talker_system(listeners=(("a", 1), ("b", 3))), "talker", "talker_v2", strategy="paper")
    sec = plan.seconds()
    assert sec.weighted == pytest.approx(sec.seconds[("a", "listen")] + 3 * sec.seconds[("b", "listen")])


def test_the_default_strategy_creates_before_degrading_on_a_single_topic() -> None:
    """On a `single` topic the listener must degrade; the create of talker_v2 is not in its window."""
    plan = plan_replace(talker_system(single=True), "talker", "talker_v2")
    kinds = [a.kind for a in plan.steps]
    assert kinds.index("create") < kinds.index("degrade")
    times = durations(plan.system)
    assert plan.seconds().seconds[("listener", "listen")] < times.kinds["create"]
    paper = plan_replace(talker_system(single=True), "talker", "talker_v2", strategy="paper")
    assert paper.seconds().weighted > plan.seconds().weighted


def test_an_ftm_transition_prepares_its_new_nodes_before_suspending() -> None:
    """PBR → LFR: the four new Before/After nodes are created before the first degrade, so what
    the client's side waits does not depend on how long a create takes."""
    plan = plan_transition(load([os.path.join(EXAMPLES, "ftm", "deterministic_pbr.arch")]), "server", "LFR").plan
    first = next(i for i, a in enumerate(plan.steps) if isinstance(a, Degrade))
    creates = [i for i, a in enumerate(plan.steps) if isinstance(a, Create)]
    assert len(creates) == 4 and max(creates) < first
    times = durations(plan.system)
    slow = Durations({**times.kinds, "create": 100 * times.kinds["create"]})
    waits = [degraded_seconds(plan.system, plan.states[0], plan.steps, t, plan.batches).seconds[("follower", "follow")]
             for t in (times, slow)]
    assert waits[0] == pytest.approx(waits[1])


def test_prepare_first_keeps_a_plan_it_cannot_improve() -> None:
    plan = plan_replace(talker_system(), "talker", "talker_v2")      # nothing that served degrades
    times = durations(plan.system)
    assert prepare_first(plan.system, plan.states[0], plan.steps, plan.goal, times) is plan.steps


def test_a_move_the_preconditions_refuse_is_not_made() -> None:
    """Moving the listener's upgrade (index 6) to the front would upgrade it with no publisher:
    refused all at once, so it goes as far forward as the checks allow, and the plan stays valid."""
    plan = plan_replace(talker_system(), "talker", "talker_v2", strategy="paper")
    start, goal = plan.states[0], plan.goal
    moved = _move(plan.system, start, plan.steps, goal, [6], front=True)
    assert cost(plan.system, start, moved, goal) is not None
    assert moved == plan.steps        # it needs talker_v2 attached, the step just before it
    verify(plan.system, start, moved, goal, "test")
    # a remove moved last: valid, and the plan still verifies
    later = _move(plan.system, start, plan.steps, goal, [2], front=False)
    assert later[-1].kind == "remove" and cost(plan.system, start, later, goal) is not None
