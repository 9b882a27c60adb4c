"""Alloy as a second planner: its plans are safe (the Python engine re-checks them) and as
little disruptive as the exhaustive search's."""
from __future__ import annotations

from dataclasses import replace

import pytest

from checker.alloy import AlloyBridge
from checker.planning.alloy_search import alloy_plan, alloy_search, plan_with_alloy, render_planner
from checker.planning.plan import Goal, NoSafePlan, Problem, ready, verify
from checker.planning.strategies import solve
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES
from tests.support.random_systems import random_system
from tests.support.systems import chain_system, talker_system

CHATTER = next(e for e in EXAMPLES if e.name == "chatter").file


def replace_problem(system: System, old: str, new: str) -> Problem:
    """Replace `old` by the version `new`, as operations.plan_replace states it."""
    start = Configuration.initial(system)
    comp = system.component(new)
    assert comp is not None
    roles = {r for r in start.roles if r[1] != old}
    roles |= {(k, new, p) for k, c, p in start.roles if c == old and comp.port(p) is not None}
    goal = Goal((start.components - {old}) | {new}, frozenset(roles))
    return ready(Problem(system, start, goal, replaced=[(old, new)]))


def remove_problem(system: System, old: str) -> Problem:
    start = Configuration.initial(system)
    goal = Goal(start.components - {old}, frozenset(r for r in start.roles if r[1] != old))
    return ready(Problem(system, start, goal, removed=[old]))


def _generated() -> list[tuple[str, Problem]]:
    out = []
    for seed in (1, 2, 3, 5):
        s = random_system(seed, n=3, n_topics=2)
        if s is not None:
            out.append((f"gen{seed}", replace_problem(s, "c0", "c0_v2")))
    return out


# (name, problem, steps allowed: at least the exhaustive plan's length)
CASES = [
    ("chatter", lambda: replace_problem(load([CHATTER]), "talker", "talker_v2"), 6),
    ("redundant", lambda: replace_problem(talker_system(second_talker=True), "talker", "talker_v2"), 6),
    ("single", lambda: replace_problem(talker_system(single=True, listeners=(("a", 2), ("b", 1))),
                                       "talker", "talker_v2"), 9),
    ("chain", lambda: replace_problem(chain_system(2), "r0", "r0_v2"), 8),
    ("remove-publisher", lambda: remove_problem(talker_system(), "talker"), 4),
]


@pytest.mark.parametrize("name,make,max_steps", CASES, ids=[c[0] for c in CASES])
def test_alloy_plan_is_safe_and_least_disruptive(bridge: AlloyBridge, name: str, make: object,
                                                 max_steps: int) -> None:
    problem = make()  # type: ignore[operator]
    search = alloy_search(problem, max_steps=max_steps, bridge=bridge)
    print(name, [(s.bound, s.found, s.steps, s.disruption, round(s.seconds, 2)) for s in search.solves])
    plan = verify(problem.system, problem.start, search.steps, problem.goal, "alloy")
    optimum = solve(problem, "exhaustive")
    assert plan.disruption == search.disruption == optimum.disruption
    assert len(plan) == len(optimum)  # then fewest steps, as the search orders them
    assert search.optimal and not search.solves[-1].found


def test_generated_systems(bridge: AlloyBridge) -> None:
    cases = _generated()
    compared = 0
    for name, problem in cases:
        try:
            optimum = solve(problem, "exhaustive")
        except NoSafePlan:
            with pytest.raises(NoSafePlan):
                alloy_search(problem, max_steps=6, bridge=bridge)
            continue
        if len(optimum) > 8:
            continue
        search = alloy_search(problem, max_steps=len(optimum), bridge=bridge)
        plan = verify(problem.system, problem.start, search.steps, problem.goal, "alloy")
        assert plan.disruption == optimum.disruption, name
        compared += 1
    assert compared >= 3


def test_plan_with_alloy_returns_a_checked_plan(bridge: AlloyBridge) -> None:
    problem = replace_problem(load([CHATTER]), "talker", "talker_v2")
    plan = plan_with_alloy(problem, max_steps=6)
    assert plan.strategy == "alloy"
    assert plan.goal.reached(plan.states[-1])
    assert [a.kind for a in plan.steps] == ["create", "upgrade", "attach", "detach", "remove"]
    assert plan.disruption == 1
    assert any(n.startswith("alloy:") for n in plan.notes)


def test_alloy_plan_gives_actions(bridge: AlloyBridge) -> None:
    problem = replace_problem(talker_system(), "talker", "talker_v2")
    steps = alloy_plan(problem, max_steps=6)
    assert verify(problem.system, problem.start, steps, problem.goal, "alloy").disruption == 1


def test_nothing_to_do_is_the_empty_plan() -> None:
    system = load([CHATTER])
    start = Configuration.initial(system)
    problem = Problem(system, start, Goal(start.components, start.roles))
    assert alloy_plan(problem) == []


def test_too_few_steps_is_no_plan(bridge: AlloyBridge) -> None:
    problem = replace_problem(load([CHATTER]), "talker", "talker_v2")
    with pytest.raises(NoSafePlan, match="at most 3 steps"):
        alloy_search(problem, max_steps=3, bridge=bridge)


def test_module_reuses_the_shared_semantics_and_actions() -> None:
    problem = replace_problem(load([CHATTER]), "talker", "talker_v2")
    text, names = render_planner(problem, max_steps=4, bound=2)
    assert "var comps: set Component" in text
    assert "pred valid[s: System]" in text and "pred upgrade[s: System, f: Functionality]" in text
    assert "(s.degraded)' = s.degraded + f" in text
    assert "1..5 steps" in text and "var spent" in text
    unbounded, _ = render_planner(replace(problem), max_steps=4)
    assert "spent" not in unbounded
    assert names["c_talker__v2"] == ("component", "talker_v2")
