"""Every plan the planner returns is accepted by Alloy (`alloy_evidence`), whatever the
strategy; a corrupted plan is refused with a reason that names the step."""
from __future__ import annotations

from dataclasses import replace

import pytest

from checker.alloy import AlloyBridge
from checker.planning import NoSafePlan, Plan, plan_remove, plan_replace
from checker.planning.alloy_verify import alloy_evidence
from checker.planning.plan import run_actions
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES

STRATEGIES = ("paper", "default", "exhaustive")
CHATTER = next(e for e in EXAMPLES if e.name == "chatter").file
ROBOT = next(e for e in EXAMPLES if e.name == "robot").file


def _plan(kind: str, strategy: str) -> Plan:
    try:
        if kind == "replace talker":
            return plan_replace(load([CHATTER]), "talker", "talker_v2", strategy)
        return plan_remove(load([ROBOT]), "obstacle_detector", strategy)
    except NoSafePlan as err:
        pytest.skip(f"the planner has no {strategy} plan to {kind}: {err}")


@pytest.mark.parametrize("strategy", STRATEGIES)
@pytest.mark.parametrize("kind", ["replace talker", "remove obstacle_detector"])
def test_planner_plans_are_accepted(bridge: AlloyBridge, kind: str, strategy: str) -> None:
    plan = _plan(kind, strategy)
    evidence = alloy_evidence(plan)
    assert evidence["valid"], evidence["reason"]
    assert evidence["states"] == len(plan.states) == len(plan.steps) + 1


def _corrupted(plan: Plan, steps: list) -> Plan:  # type: ignore[type-arg]
    return replace(plan, steps=steps, states=run_actions(plan.system, plan.states[0], steps))


def test_swapped_steps_are_refused(bridge: AlloyBridge) -> None:
    plan = _plan("replace talker", "paper")
    assert [a.kind for a in plan.steps[:2]] == ["degrade", "detach"]
    steps = [plan.steps[1], plan.steps[0], *plan.steps[2:]]
    evidence = alloy_evidence(_corrupted(plan, steps))
    assert not evidence["valid"]
    # the plan's own first step is judged: its preconditions fail in the first state
    assert evidence["reason"].startswith(f"step 1 ({steps[0].describe()}) is not an instance of {steps[0].kind}")


def test_dropped_degrade_is_refused(bridge: AlloyBridge) -> None:
    plan = _plan("replace talker", "paper")
    steps = [a for a in plan.steps if a.kind != "degrade"]
    evidence = alloy_evidence(_corrupted(plan, steps))
    assert not evidence["valid"]
    assert "step 1 (detach" in evidence["reason"]


def test_create_of_a_present_component_is_refused(bridge: AlloyBridge) -> None:
    """States that stay valid but a step whose preconditions fail: create before remove of
    the same component (the second create finds it present)."""
    plan = _plan("replace talker", "paper")
    create = next(i for i, a in enumerate(plan.steps) if a.kind == "create")
    steps = [*plan.steps[:create + 1], plan.steps[create], *plan.steps[create + 1:]]
    states = run_actions(plan.system, plan.states[0], steps)
    evidence = alloy_evidence(replace(plan, steps=steps, states=states))
    assert not evidence["valid"]
    assert f"step {create + 2} (create" in evidence["reason"]
