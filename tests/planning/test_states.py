"""A plan's states held as its steps and checkpoints (checker.planning.states) read as the list of
every state would, and what is derived from them (degradation, the document's changes) agrees with
a direct reading of every state."""
from __future__ import annotations

from itertools import pairwise

import pytest

from bench.gen import generate
from checker.planning import plan_replace
from checker.planning import states as states_module
from checker.planning.plan import Plan, degradation, state_change, state_dict
from checker.planning.states import States
from checker.semantic_model.actions import effect
from checker.semantic_model.config import Configuration
from codegen.ros2 import state_at
from reconf_dsl.loader import load_text
from reconf_ros.executor.plan_states import PlanStates


@pytest.fixture()
def plan(monkeypatch: pytest.MonkeyPatch) -> Plan:
    """A plan several checkpoints long (one state in 4 kept): replacing the hub of a fan-in."""
    monkeypatch.setattr(states_module, "EVERY", 4)
    monkeypatch.setattr(PlanStates, "EVERY", 4)
    system = load_text(generate("fanin", 300, seed=1, version=True), "fanin.arch")
    plan = plan_replace(system, "hub", "hub_v2", "default")
    assert len(plan.steps) > 3 * 4 and {a.kind for a in plan.steps} >= {"create", "remove", "attach", "detach"}
    return plan


def every_state(plan: Plan) -> list[Configuration]:
    states = [plan.states[0]]
    for a in plan.steps:
        states.append(effect(plan.system, states[-1], a))
    return states


def test_states_read_as_a_list(plan: Plan) -> None:
    full = every_state(plan)
    states = plan.states
    assert isinstance(states, States) and len(states) == len(full)
    assert states == full and list(states) == full
    for i in (0, 1, states_module.EVERY - 1, states_module.EVERY, states_module.EVERY + 1, len(full) // 2, len(full) - 1, -1, -states_module.EVERY - 3):
        assert states[i] == full[i]
    for i in reversed(range(0, len(full), 7)):          # backwards: each read replays from a checkpoint
        assert states[i] == full[i]
    assert list(states[1:]) == full[1:] and list(states[5:states_module.EVERY * 2 + 3]) == full[5:states_module.EVERY * 2 + 3]
    assert list(states[::states_module.EVERY]) == full[::states_module.EVERY] and states[2:][3] == full[5]
    with pytest.raises(IndexError):
        states[len(full)]


def test_degradation_agrees_with_every_state(plan: Plan) -> None:
    steps: dict[str, int] = {}
    run: dict[str, int] = {}
    longest: dict[str, int] = {}
    for state in every_state(plan)[1:]:
        now = {f"{c}.{f}" for c, f in state.degraded if c in state.components}
        for name in now:
            steps[name] = steps.get(name, 0) + 1
            run[name] = run.get(name, 0) + 1
            longest[name] = max(longest.get(name, 0), run[name])
        for name in set(run) - now:
            run[name] = 0
    got = degradation(plan)
    assert got["functionalities"] == dict(sorted(steps.items())) and steps
    assert got["longest"] == max(longest.values())
    assert got["longest_functionality"] == max(longest, key=lambda k: (longest[k], k))


def test_the_document_holds_changes_that_give_every_state(plan: Plan) -> None:
    doc = plan.to_dict()
    full = every_state(plan)
    assert "states" not in doc and len(doc["changes"]) == len(plan.steps)
    assert doc["changes"] == [state_change(a, b) for a, b in pairwise(full)]
    read = PlanStates(doc)
    assert len(read) == len(full) and [st.key() for st in read] == [(s.components, s.degraded, s.roles) for s in full]
    for i in (len(full) - 1, 3, 0, len(full) // 2, -2, 5, 4):        # out of order: replayed from checkpoints
        assert read[i].key() == (full[i].components, full[i].degraded, full[i].roles)
    assert state_at(doc, -1) == state_dict(full[-1]) and state_at(doc, 3) == state_dict(full[3])
    assert len(read.kept) <= len(full) // 4 + 2            # one state in EVERY (4 here) and the last
    # a version-1 document (every state in full) reads the same
    v1 = dict(doc, states=[state_dict(s) for s in full])
    assert [st.key() for st in PlanStates(v1)] == [st.key() for st in read]
