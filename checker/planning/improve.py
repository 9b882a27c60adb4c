"""Local improvement of a plan: drop needless degrade/upgrade pairs, move steps.

Repeats, until nothing gets better: every step, and every pair of consecutive steps (a
degrade with the detach it allows), is tried at every other position; every degrade
(upgrade) is tried away together with the upgrade (degrade) that undoes it. A candidate is
kept when every step's preconditions hold and it reaches the goal at a lower (disruption,
length). Each round strictly lowers the cost, and budgets bound the candidates tried and the
steps simulated.
"""
from __future__ import annotations

from typing import Iterator, Optional, Sequence

from checker.planning.plan import Goal, next_weight, state_weight
from checker.planning.states import States
from checker.semantic_model.actions import Action, Degrade, Snapshot, Upgrade, catalogue, check, effect
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System

__all__ = ["improve", "cost"]


def cost(system: System, start: Configuration, steps: Sequence[Action], goal: Goal) -> Optional[tuple[int, int]]:
    """(disruption, length) of `steps`, or None when a step is refused or the goal is missed."""
    cat = catalogue(system)
    config, total, weight = start, 0, state_weight(system, start)
    for a in steps:
        if check(Snapshot(cat, config), a):
            return None
        after = effect(system, config, a)
        weight = next_weight(system, config, weight, a, after)
        config = after
        total += weight
    return (total, len(steps)) if goal.reached(config) else None


def _variants(steps: list[Action]) -> Iterator[tuple[int, list[Action]]]:
    """Candidate plans, each with the index of its first step that differs from `steps`."""
    for i, a in enumerate(steps):
        if isinstance(a, (Degrade, Upgrade)):
            undo = Upgrade if isinstance(a, Degrade) else Degrade
            for j in range(i + 1, len(steps)):
                b = steps[j]
                if isinstance(b, undo) and (b.component, b.functionality) == (a.component, a.functionality):
                    yield i, steps[:i] + steps[i + 1:j] + steps[j + 1:]
                    break
    for width in (1, 2):
        for i in range(len(steps) - width + 1):
            block, rest = steps[i:i + width], steps[:i] + steps[i + width:]
            for j in range(len(rest) + 1):
                if j != i:
                    yield min(i, j), rest[:j] + block + rest[j:]


class _Budget:
    """How many more steps may be simulated."""

    def __init__(self, steps: float) -> None:
        self.left = steps


def _tail_cost(system: System, config: Configuration, total: int, steps: Sequence[Action], goal: Goal,
               bound: tuple[int, int], budget: _Budget) -> Optional[tuple[int, int]]:
    """Cost of running `steps` from `config` with `total` so far; None if refused or not below `bound`."""
    cat = catalogue(system)
    weight = state_weight(system, config)
    for a in steps:
        budget.left -= 1
        if check(Snapshot(cat, config), a):
            return None
        after = effect(system, config, a)
        weight = next_weight(system, config, weight, a, after)
        config = after
        total += weight
        if total > bound[0]:
            return None
    return (total, bound[1]) if goal.reached(config) else None


def improve(system: System, start: Configuration, steps: list[Action], goal: Goal, rounds: int = 50,
            budget: int = 20_000, work: int = 60_000) -> list[Action]:
    """Locally better `steps`; at most `rounds` improvements, `budget` candidates tried and `work`
    steps simulated, quadratically fewer on systems of more than 20 components (so long plans on
    big systems are improved only as far as that allows)."""
    if cost(system, start, steps, goal) is None:
        return steps
    # A simulated step costs about the degree of what it touches, and long plans have
    # quadratically many variants: beyond 20 components, far fewer steps are simulated.
    sim = _Budget(work * min(1.0, (20 / max(1, len(start.components))) ** 2))
    for _ in range(rounds):
        weights, kept = [0], {0: start}
        config, weight = start, state_weight(system, start)
        for i, a in enumerate(steps, 1):
            after = effect(system, config, a)
            weight = next_weight(system, config, weight, a, after)
            weights.append(weights[-1] + weight)
            if States.keep(i, len(steps)):
                kept[i] = after
            config = after
        states = States(system, start, steps, kept)      # not every state: see checker.planning.states
        best = (weights[-1], len(steps))
        found = None
        for k, cand in _variants(steps):
            budget -= 1
            if budget < 0 or sim.left < 0:
                return steps
            c = _tail_cost(system, states[k], weights[k], cand[k:], goal, best, sim)
            if c is not None and (c[0], len(cand)) < best:
                found = cand
                break
        if found is None:
            return steps
        steps = found
    return steps
