"""Prepare first, clean up last: a plan's steps ordered for its time on the wire
(docs/soundness.md#prepare-first-clean-up-last).

A component the plan creates serves no one until its first upgrade: its `create` and the
attaches of its inputs before that upgrade (*preparing* steps) disturb nothing that runs, and a
`remove` takes away a component nothing reads any more. On the wire a create is the slowest
step by far (a process start and a discovery round, `KINDS`' `seconds`), so where it falls
inside a degraded window it is most of that window. `prepare_first` moves the preparing steps,
in their order, before everything else and the removes after everything else, where every
step's preconditions still hold (each move is checked on its own, so one that would break a
state is left where it was), and keeps the new order only when its degraded seconds
(`checker.planning.durations`) are lower. The plan is then verified as any plan.
"""
from __future__ import annotations

from typing import Sequence

from checker.planning.durations import Durations, degraded_seconds
from checker.planning.improve import cost
from checker.planning.plan import Goal
from checker.semantic_model.actions import Action, Attach, Create, Remove, Upgrade
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System

__all__ = ["prepare_first"]

TRIALS = 200
"""How many orders the single moves may check, at most (each check replays the plan)."""


def _preparing(system: System, start: Configuration, steps: Sequence[Action], inputs: bool) -> list[int]:
    """The indices of the preparing steps: creates of new components, and (with `inputs`)
    attaches of their inputs before their first upgrade."""
    new = {a.component for a in steps if isinstance(a, Create) and a.component not in start.components}
    upgraded: set[str] = set()
    out = []
    for i, a in enumerate(steps):
        if isinstance(a, Upgrade):
            upgraded.add(a.component)
        elif isinstance(a, Create) and a.component in new:
            out.append(i)
        elif inputs and isinstance(a, Attach) and a.component in new and a.component not in upgraded:
            comp = system.component(a.component)
            port = comp.port(a.port) if comp is not None else None
            if port is not None and port.kind == "input":
                out.append(i)
    return out


def _move(system: System, start: Configuration, steps: list[Action], goal: Goal, picked: list[int],
          front: bool) -> list[Action]:
    """`steps` with the `picked` ones (indices) moved to the front (the back), in their order,
    all at once where the checks allow, or else each on its own as far as they allow."""
    if not picked:
        return steps
    chosen = set(picked)
    moved = [steps[i] for i in picked]
    rest = [a for i, a in enumerate(steps) if i not in chosen]
    cand = moved + rest if front else rest + moved
    if cand == steps:
        return steps
    if cost(system, start, cand, goal) is not None:      # every precondition holds, the goal is reached
        return cand
    tagged, trials = list(enumerate(steps)), TRIALS
    for k in picked if front else reversed(picked):
        i = next(n for n, (orig, _) in enumerate(tagged) if orig == k)
        item, others = tagged[i], tagged[:i] + tagged[i + 1:]
        for j in (range(0, i) if front else range(len(others), i, -1)):
            trials -= 1
            if trials < 0:
                return [a for _, a in tagged]
            trial = others[:j] + [item] + others[j:]
            if cost(system, start, [a for _, a in trial], goal) is not None:
                tagged = trial
                break
    return [a for _, a in tagged]


def prepare_first(system: System, start: Configuration, steps: list[Action], goal: Goal,
                  times: Durations, inputs: bool = True, removes: bool = True) -> list[Action]:
    """`steps` with the preparing steps first (the creates, and with `inputs` the attaches of the
    new components' inputs) and (with `removes`) the removes last, where that keeps every
    precondition and lowers the degraded seconds; `steps` unchanged otherwise."""
    before = degraded_seconds(system, start, steps, times).weighted    # `steps` is a checked plan
    if not before:
        return steps
    out = _move(system, start, steps, goal, _preparing(system, start, steps, inputs), front=True)
    if removes:
        out = _move(system, start, out, goal, [i for i, a in enumerate(out) if isinstance(a, Remove)], front=False)
    # every order `_move` returns was checked
    return out if degraded_seconds(system, start, out, times).weighted < before else steps
