"""Local improvement of a plan: drop needless degrade/upgrade pairs, move single steps.

Repeats, until nothing gets better: for every step, try it at every other position; for every
degrade, try the plan without it and without the upgrade that undoes it. A candidate is kept
when every step's preconditions hold and it reaches the goal with less (disruption, length).
Each round strictly lowers the cost, so this terminates.
"""
from __future__ import annotations

from typing import Iterator, Optional, Sequence

from reconf_dsl.ir import System

from ..actions import Action, Degrade, Snapshot, Upgrade, catalogue, check, effect
from ..config import Configuration
from .plan import Goal, state_weight

__all__ = ["improve", "cost"]


def cost(system: System, start: Configuration, steps: Sequence[Action], goal: Goal) -> Optional[tuple[int, int]]:
    """(disruption, length) of `steps`, or None when a step is refused or the goal is missed."""
    cat = catalogue(system)
    config, total = start, 0
    for a in steps:
        if check(Snapshot(cat, config), a):
            return None
        config = effect(system, config, a)
        total += state_weight(system, config)
    return (total, len(steps)) if goal.reached(config) else None


def _variants(steps: list[Action]) -> Iterator[list[Action]]:
    for i, a in enumerate(steps):
        if isinstance(a, Degrade):
            for j in range(i + 1, len(steps)):
                b = steps[j]
                if isinstance(b, Upgrade) and (b.component, b.functionality) == (a.component, a.functionality):
                    yield steps[:i] + steps[i + 1:j] + steps[j + 1:]
                    break
    for i in range(len(steps)):
        rest = steps[:i] + steps[i + 1:]
        for j in range(len(steps)):
            if j != i:
                yield rest[:j] + [steps[i]] + rest[j:]


def improve(system: System, start: Configuration, steps: list[Action], goal: Goal, rounds: int = 50) -> list[Action]:
    best = cost(system, start, steps, goal)
    if best is None:
        return steps
    for _ in range(rounds):
        found = None
        for cand in _variants(steps):
            c = cost(system, start, cand, goal)
            if c is not None and c < best:
                found, best = cand, c
                break
        if found is None:
            return steps
        steps = found
    return steps
