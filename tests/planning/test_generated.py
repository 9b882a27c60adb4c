"""Strategies compared on generated systems: default ≤ paper always, default = optimum mostly.

The shares are printed (run with -s to see them) and bounded from below, so a regression in
the default strategy shows up as a failure.
"""
from __future__ import annotations

import functools
from typing import Callable, Optional, Sequence

from checker.planning import NoSafePlan, Plan, plan_migrate, plan_replace
from checker.planning.default import default_steps
from checker.planning.improve import cost
from tests.support.random_systems import random_migration, random_system

from .test_planning import assert_safe


def _try(make: Callable[[], Plan]) -> Optional[Plan]:
    try:
        return make()
    except NoSafePlan:
        return None


def _compare(cases: Sequence[tuple[str, Callable[[str], Plan]]]) -> dict[str, int]:
    n = better = optimal = own_optimal = 0
    for _, make in cases:
        optimum = _try(lambda: make("exhaustive"))
        default = _try(lambda: make("default"))
        paper = _try(lambda: make("paper"))
        # default finds a plan whenever the paper or the search does
        assert (default is None) == (optimum is None)
        assert paper is None or default is not None
        if default is None or optimum is None:
            continue
        assert_safe(default)
        n += 1
        assert optimum.disruption <= default.disruption
        if paper is not None:
            assert default.disruption <= paper.disruption
            better += default.disruption < paper.disruption
        optimal += default.disruption == optimum.disruption
        own = cost(default.system, default.states[0], default_steps(default.system, default.states[0], default.goal),
                   default.goal)
        own_optimal += own is not None and own[0] == optimum.disruption
    return {"planned": n, "default<paper": better, "default=optimum": optimal,
            "default=optimum without the paper's plan": own_optimal}


def test_replace_on_generated_systems() -> None:
    cases: list[tuple[str, Callable[[str], Plan]]] = []
    for seed in range(120):
        s = random_system(seed, n=4)
        if s is not None:
            cases.append((f"replace/{seed}", functools.partial(plan_replace, s, "c0", "c0_v2")))
    stats = _compare(cases)
    print("replace:", stats)
    assert stats["planned"] >= 100
    assert stats["default=optimum"] >= 0.95 * stats["planned"]
    assert stats["default<paper"] >= 0.3 * stats["planned"]


def test_migrate_on_generated_systems() -> None:
    cases: list[tuple[str, Callable[[str], Plan]]] = []
    for seed in range(50):
        m = random_migration(seed, n=4)
        if m is not None:
            cases.append((f"migrate/{seed}", functools.partial(plan_migrate, m[0], m[1])))
    stats = _compare(cases)
    print("migrate:", stats)
    assert stats["planned"] >= 40
    assert stats["default=optimum"] >= 0.95 * stats["planned"]
    assert stats["default<paper"] >= 0.1 * stats["planned"]
