"""Planners: the paper's plan, and what the default and exhaustive strategies do better."""
from __future__ import annotations

import os
from dataclasses import replace

import pytest

from checker.planning import STRATEGIES, NoSafePlan, Plan, plan_add, plan_migrate, plan_remove, plan_replace
from checker.planning.plan import disruption
from checker.semantic_model.actions import Attach, Degrade, Detach, preconditions
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl.ir import PortRef
from reconf_dsl.loader import load
from tests.support.systems import chain_system, ring_system, talker_system

EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "examples")

PAPER_PLAN = [
    "degrade listener.listen",
    "detach talker.out from /chatter",
    "remove talker",
    "create talker_v2 (all functionalities degraded)",
    "upgrade talker_v2.talk",
    "attach talker_v2.out to /chatter",
    "upgrade listener.listen",
]


def assert_safe(plan: Plan) -> None:
    """Independent re-check: every step allowed and every state valid by the engine."""
    for before, action, after in zip(plan.states, plan.steps, plan.states[1:]):
        assert preconditions(plan.system, before, action) == []
        assert evaluate(plan.system, after, explain=False).valid
    assert plan.goal.reached(plan.states[-1])
    assert plan.disruption == disruption(plan.system, plan.states)


def publishers(plan: Plan, state: Configuration, conn: str) -> list[str]:
    return [c for n, c, p in state.roles if n == conn and c in state.components
            and plan.system.component(c).port(p).kind == "output"]  # type: ignore[union-attr]


def test_paper_strategy_gives_the_seven_steps_of_the_paper() -> None:
    plan = plan_replace(talker_system(), "talker", "talker_v2", "paper")
    assert [a.describe() for a in plan.steps] == PAPER_PLAN
    assert_safe(plan)
    assert plan.disruption == 7      # listener degraded in six states, talker_v2.talk in one


def test_default_makes_before_it_breaks() -> None:
    plan = plan_replace(talker_system(), "talker", "talker_v2")
    assert [a.describe() for a in plan.steps] == [
        "create talker_v2 (all functionalities degraded)", "upgrade talker_v2.talk",
        "attach talker_v2.out to /chatter", "detach talker.out from /chatter", "remove talker"]
    assert plan.disruption == 1
    assert_safe(plan)
    assert plan_replace(talker_system(), "talker", "talker_v2", "exhaustive").disruption == 1


def test_single_topic_forbids_make_before_break() -> None:
    s = talker_system(single=True)
    for strategy in STRATEGIES:
        plan = plan_replace(s, "talker", "talker_v2", strategy)
        assert_safe(plan)
        assert all(len(publishers(plan, state, "/chatter")) <= 1 for state in plan.states)
        assert Degrade("listener", "listen") in plan.steps
    paper = plan_replace(s, "talker", "talker_v2", "paper")
    assert plan_replace(s, "talker", "talker_v2").disruption < paper.disruption


def test_redundant_publisher_avoids_degradation() -> None:
    s = talker_system(single=False, second_talker=True)
    for strategy in STRATEGIES:
        for plan in (plan_replace(s, "talker", "talker_v2", strategy), plan_remove(s, "talker", strategy)):
            assert_safe(plan)
            assert not any(isinstance(a, Degrade) for a in plan.steps)
    assert plan_remove(s, "talker").disruption == 0


def test_criticality_decides_the_order() -> None:
    light_heavy = talker_system(single=True, listeners=(("l1", 1), ("l2", 5)))
    heavy_light = talker_system(single=True, listeners=(("l1", 5), ("l2", 1)))
    for s, heavy in ((light_heavy, "l2"), (heavy_light, "l1")):
        plan = plan_replace(s, "talker", "talker_v2")
        assert_safe(plan)
        degrades = [a.component for a in plan.steps if isinstance(a, Degrade)]
        upgrades = [a.component for a in plan.steps if a.kind == "upgrade" and a.component != "talker_v2"]
        assert degrades[-1] == heavy and upgrades[0] == heavy     # degraded last, upgraded first
        assert plan.disruption == plan_replace(s, "talker", "talker_v2", "exhaustive").disruption == 21
        assert plan.disruption < plan_replace(s, "talker", "talker_v2", "paper").disruption


def test_cycles_terminate_with_every_step_valid() -> None:
    for serves in (True, False):
        s = ring_system(degraded_still_serves=serves)
        for strategy in ("default", "exhaustive"):
            assert_safe(plan_replace(s, "a", "a_v2", strategy))
    # The paper's recursion meets itself on the ring; guarded, it stops and says why.
    with pytest.raises(NoSafePlan, match="cannot degrade b.relay"):
        plan_replace(ring_system(degraded_still_serves=False), "a", "a_v2", "paper")
    assert_safe(plan_replace(ring_system(degraded_still_serves=True), "a", "a_v2", "paper"))


def test_single_topic_ring_has_no_safe_plan() -> None:
    s = ring_system(degraded_still_serves=False)
    s = replace(s, connectors=tuple(replace(c, single=True) for c in s.connectors))
    for strategy in STRATEGIES:
        with pytest.raises(NoSafePlan):
            plan_replace(s, "a", "a_v2", strategy)


def test_no_safe_plan_says_why() -> None:
    s = talker_system()
    bad = replace(Configuration.initial(s), degraded=frozenset({("talker", "talk")}))
    with pytest.raises(NoSafePlan) as e:
        plan_remove(s, "talker", config=bad)
    assert e.value.reasons == ["the current configuration is not valid: listener.listen assumes String @ 10 Hz, "
                               "which does not hold"]


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_removing_the_only_publisher_leaves_its_reader_degraded(strategy: str) -> None:
    plan = plan_remove(talker_system(), "talker", strategy)
    assert_safe(plan)
    assert plan.goal.degraded == {("listener", "listen")} == plan.states[-1].degraded
    assert plan.notes[0] == "listener.listen stays degraded: it assumes String @ 10 Hz, which cannot hold in the target"
    assert plan.summary().endswith("left degraded: listener.listen")
    assert plan.to_dict()["left_degraded"][0]["functionality"] == "listen"


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_removing_the_obstacle_detector_stops_the_robot(strategy: str) -> None:
    """Paper 001 §3.1: without obstacles the controller degrades (it stops the robot); its degraded
    mode still publishes Twist @ 20 Hz, so the base driver stays normal."""
    robot = load([os.path.join(EXAMPLES, "robot.arch")])
    plan = plan_remove(robot, "obstacle_detector", strategy)
    assert_safe(plan)
    assert plan.goal.degraded == {("motor_controller", "control")}
    assert plan.states[-1].degraded == {("motor_controller", "control")}
    assert plan.steps[-1].describe() == "remove obstacle_detector"
    assert Degrade("motor_controller", "control") in plan.steps
    assert not any(a.kind == "degrade" and a.component == "base_driver" for a in plan.steps)
    assert plan.notes[0] == ("motor_controller.control stays degraded: it assumes Obstacles @ 1 s, which cannot "
                             "hold in the target")
    assert plan.disruption == 5 * 3     # degraded in the states after the degrade, the detach, the removal


def test_chained_residual_degradation() -> None:
    """Degrading one reader can starve another: the goal's degraded set is a fixpoint."""
    for strategy in STRATEGIES:
        plan = plan_remove(chain_system(3), "r0", strategy)
        assert_safe(plan)
        assert plan.goal.degraded == {("r1", "relay"), ("r2", "relay")}
        assert "r2.relay stays degraded: it assumes String @ 10 Hz, which cannot hold in the target" in plan.notes
        # r1's degraded mode still serves /t1: r2 keeps working
        plan = plan_remove(chain_system(3, serves=(False, True)), "r0", strategy)
        assert_safe(plan)
        assert plan.goal.degraded == {("r1", "relay")}


def test_add_a_publisher_and_a_listener() -> None:
    full = talker_system(second_talker=True, listeners=(("listener", 1), ("extra", 2)))
    base = talker_system()
    plan = plan_add(base, "backup", source=full)
    assert_safe(plan)
    assert Attach("/chatter", "backup", "out") in plan.steps and plan.disruption == 1
    plan = plan_add(base, "extra", source=full)
    assert_safe(plan)
    assert plan.steps[-1].describe() == "upgrade extra.listen"


def test_migrate_adds_removes_replaces_and_rewires() -> None:
    old = talker_system(second_talker=True, listeners=(("listener", 1), ("gone", 1)))
    new = talker_system(listeners=(("listener", 3), ("extra", 1)))  # backup and gone leave; listener redefined
    new = replace(new, connectors=new.connectors + (replace(new.connectors[0], name="/copy", publishers=(
        PortRef("talker", "out"),), subscribers=()),))                # talker.out also on /copy
    for strategy in STRATEGIES:
        plan = plan_migrate(old, new, strategy)
        assert_safe(plan)
        done = {a.describe() for a in plan.steps}
        assert {"remove backup", "remove gone", "remove listener", "attach talker.out to /copy"} <= done
        assert "create extra (all functionalities degraded)" in done
        assert plan.renames == {"listener@new": "listener"}
        assert not any(isinstance(a, Detach) and a.component == "talker" for a in plan.steps)
    assert plan_migrate(old, new).disruption <= plan_migrate(old, new, "paper").disruption


def test_migrate_to_itself_is_empty() -> None:
    s = talker_system()
    for strategy in STRATEGIES:
        assert plan_migrate(s, s, strategy).steps == []


@pytest.mark.parametrize("n", [3, 5, 8])
@pytest.mark.parametrize("single", [False, True])
@pytest.mark.parametrize("ring", [False, True])
def test_chains_and_rings_of_relays(n: int, single: bool, ring: bool) -> None:
    """Every strategy stops on cycles too; whatever it returns is safe, and default is optimal here."""
    s = chain_system(n, single=single, ring=ring)
    found = {}
    for strategy in STRATEGIES:
        try:
            plan = plan_replace(s, "r0", "r0_v2", strategy)
        except NoSafePlan as e:
            assert e.reasons
            continue
        assert_safe(plan)
        found[strategy] = plan.disruption
    assert ("default" in found) == ("exhaustive" in found)
    if "exhaustive" in found:
        assert found["default"] == found["exhaustive"] <= found.get("paper", found["default"])
    if single and ring:
        assert not found     # the new relay can neither join nor wait: nothing is safe


def test_migrate_changed_connector_is_a_new_connector() -> None:
    old = talker_system()
    new = replace(old, connectors=tuple(replace(c, single=True) for c in old.connectors))
    for strategy in STRATEGIES:
        plan = plan_migrate(old, new, strategy)
        assert_safe(plan)
        assert plan.renames == {"/chatter@new": "/chatter"}
        assert Attach("/chatter@new", "talker", "out") in plan.steps


def test_plan_as_json() -> None:
    import json
    plan = plan_replace(talker_system(), "talker", "talker_v2", "paper")
    data = json.loads(json.dumps(plan.to_dict()))
    assert [s["action"] for s in data["steps"]] == [a.kind for a in plan.steps]
    assert len(data["changes"]) == len(plan.steps) and data["disruption"] == 7
    assert data["start"]["components"] == sorted(plan.states[0].components)
    assert plan.summary().startswith("7 steps")
    assert plan.describe()[0] == "  1. ↓ degrade listener.listen"
