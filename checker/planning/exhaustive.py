"""The `exhaustive` strategy: A* over configurations, cost = (disruption, number of steps).

The search space: from a configuration, the relevant actions are creating an arriving
component, removing a leaving one, attaching a wanted attachment, detaching an unwanted
one, and degrading or upgrading any present functionality. Wanted attachments are never
detached and arriving components never removed: doing so can only add steps. Within that
space the first plan popped is optimal: the heuristic never overestimates, since

- a degraded functionality of a component that stays must be upgraded (unless the goal keeps
  it degraded), one per step, so with
  weights w0 ≥ w1 ≥ … the i-th is degraded in at least i further states: Σ i·w_i;
- an arriving component is degraded in the state right after its creation: Σ of its weights;
- every differing attachment, component and degraded functionality needs one step.

`max_states` bounds the search; beyond it `SearchTooLarge` is raised (systems of about eight
components stay well within the default).
"""
from __future__ import annotations

import heapq
from itertools import count
from typing import Optional

from reconf_dsl.ir import System

from ..actions import (Action, Attach, Create, Degrade, Detach, Remove, Snapshot, Upgrade, catalogue, check,
                       effect)
from ..config import Configuration
from .plan import Goal, NoSafePlan, state_weight

__all__ = ["exhaustive_steps", "SearchTooLarge"]


class SearchTooLarge(NoSafePlan):
    pass


def _heuristic(system: System, config: Configuration, goal: Goal) -> tuple[int, int]:
    cat = catalogue(system)
    staying = sorted((cat.funcs[d].criticality for d in config.degraded - goal.degraded if d[0] in goal.components
                      and d[0] in config.components), reverse=True)
    arriving = [(c, f.name) for c in goal.components - config.components for f in cat.comps[c].functionalities]
    cost = sum(i * w for i, w in enumerate(staying)) + sum(cat.funcs[d].criticality for d in arriving)
    to_degrade = [d for d in goal.degraded - config.degraded if d[0] in config.components]
    steps = (len(config.roles ^ goal.roles) + len(config.components ^ goal.components) + len(staying)
             + len([d for d in arriving if d not in goal.degraded]) + len(to_degrade))
    return cost, steps


def _candidates(system: System, config: Configuration, goal: Goal) -> list[Action]:
    cat = catalogue(system)
    acts: list[Action] = [Create(c) for c in sorted(goal.components - config.components)]
    acts += [Remove(c) for c in sorted(config.components - goal.components)]
    acts += [Attach(*r) for r in sorted(goal.roles - config.roles) if r[1] in config.components]
    acts += [Detach(*r) for r in sorted(config.roles - goal.roles)]
    for c in sorted(config.components):
        for f in cat.comps[c].functionalities:
            acts.append(Upgrade(c, f.name) if (c, f.name) in config.degraded else Degrade(c, f.name))
    return acts


def exhaustive_steps(system: System, start: Configuration, goal: Goal, max_states: int = 100_000) -> list[Action]:
    cat = catalogue(system)
    tie = count()
    best: dict[Configuration, tuple[int, int]] = {start: (0, 0)}
    parent: dict[Configuration, tuple[Optional[Configuration], Optional[Action]]] = {start: (None, None)}
    h0 = _heuristic(system, start, goal)
    frontier: list[tuple[int, int, int, tuple[int, int], Configuration]] = [(h0[0], h0[1], next(tie), (0, 0), start)]
    expanded = 0
    while frontier:
        _, _, _, g, config = heapq.heappop(frontier)
        if g != best[config]:
            continue
        if goal.reached(config):
            return _path(parent, config)
        expanded += 1
        if expanded > max_states:
            raise SearchTooLarge([f"exhaustive: more than {max_states} configurations to explore"])
        st = Snapshot(cat, config)
        for a in _candidates(system, config, goal):
            if check(st, a):
                continue
            nxt = effect(system, config, a)
            cost = (g[0] + state_weight(system, nxt), g[1] + 1)
            if nxt in best and best[nxt] <= cost:
                continue
            best[nxt] = cost
            parent[nxt] = (config, a)
            h = _heuristic(system, nxt, goal)
            heapq.heappush(frontier, (cost[0] + h[0], cost[1] + h[1], next(tie), cost, nxt))
    raise NoSafePlan(["exhaustive: no sequence of safe actions reaches the goal"])


def _path(parent: dict[Configuration, tuple[Optional[Configuration], Optional[Action]]],
          end: Configuration) -> list[Action]:
    steps: list[Action] = []
    node: Optional[Configuration] = end
    while node is not None:
        prev, a = parent[node]
        if a is not None:
            steps.append(a)
        node = prev
    return steps[::-1]
