"""The `exhaustive` strategy: decides whether a plan exists and, as far as its budget allows,
finds one of least disruption: the relaxation (`checker.planning.relaxed`), then reachability
over the steps towards the target, then A* for the optimum, within one `Budget`. The space
searched, why leaving out the functionalities that are not `relevant` loses no plan, and why
A*'s bound never overestimates: docs/soundness.md#the-exhaustive-search.
"""
from __future__ import annotations

import heapq
import time
from dataclasses import dataclass
from itertools import count
from typing import Callable, Iterator, Optional

from checker.planning.default import _closure
from checker.planning.improve import cost, improve
from checker.planning.plan import Goal, NoSafePlan, state_weight
from checker.planning.relaxed import Relaxation, reachable
from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Snapshot,
    Upgrade,
    _Catalogue,
    catalogue,
    check,
    effect,
    satisfies,
)
from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.ir import Functionality, Predicate, System
from reconf_dsl.words import plural

__all__ = ["Budget", "Impossible", "Search", "SearchTooLarge", "exhaustive_search", "exhaustive_steps", "relevant"]


class SearchTooLarge(NoSafePlan):
    """The budget ran out before the search decided whether a plan exists."""


class Impossible(NoSafePlan):
    """No plan exists, proved by `how`: "relaxation" or "search" (see the module docstring)."""

    def __init__(self, reasons: list[str], how: str) -> None:
        super().__init__(reasons)
        self.how = how


@dataclass(frozen=True)
class Budget:
    """How far the search may go: configurations visited and seconds, both searches together."""

    states: int = 400_000
    seconds: float = 60.0


@dataclass
class Search:
    """What `exhaustive_search` found: the steps, whether they are proved least disruptive,
    and how many configurations each search visited in how long."""

    steps: list[Action]
    optimal: bool
    visited: int          # by the reachability search
    optimised: int        # by A*
    seconds: float
    incumbent: Optional[tuple[int, int]] = None     # the (disruption, steps) of the plan it started from
    kept: bool = False                              # that plan is the one returned
    over: bool = False                              # the budget ran out before A* decided

    def note(self) -> str:
        if self.kept:
            why = ("its budget ran out" if self.over else
                   "it found none as good among the configurations it searches")
            return (f"exhaustive: the default strategy's plan (disruption {self.incumbent[0] if self.incumbent else '?'}) "
                    f"is kept: A* looked for a less disruptive one over {self.optimised:,} configurations in "
                    f"{self.seconds:.1f} s, and {why}; not proved least disruptive")
        if self.optimal:
            return (f"exhaustive: least disruptive, then fewest steps (A* over {self.optimised:,} configurations, "
                    f"{self.seconds:.1f} s)")
        return (f"exhaustive: a plan found among {self.visited:,} configurations; not proved least disruptive "
                f"(A* gave up after {self.optimised:,} configurations, {self.seconds:.1f} s in all)")


class _Clock:
    """The budget as it is spent."""

    def __init__(self, budget: Budget) -> None:
        self.budget = budget
        self.began = time.perf_counter()
        self.deadline = self.began + budget.seconds
        self.visited = 0

    def spent(self) -> float:
        return time.perf_counter() - self.began

    def over(self, visited: int) -> bool:
        return visited > self.budget.states or time.perf_counter() > self.deadline


def relevant(system: System, start: Configuration, goal: Goal) -> frozenset[FuncId]:
    """The functionalities whose mode a plan may need to change (see the module docstring)."""
    cat = catalogue(system)
    staying = start.components & goal.components
    kept = start.roles & goal.roles
    readers: dict[str, set[FuncId]] = {}        # connector -> the functionalities reading it
    outputs: dict[FuncId, set[str]] = {}        # functionality -> the connectors it publishes on
    witnesses: dict[str, set[FuncId]] = {}      # connector -> kept publishers that satisfy it when normal
    for k, c, p in start.roles | goal.roles:
        port = cat.ports.get((c, p))
        if port is None or k not in cat.conns:
            continue
        for f in cat.comps[c].functionalities:
            if p not in f.ports:
                continue
            if port.kind == "input":
                readers.setdefault(k, set()).add((c, f.name))
                continue
            outputs.setdefault((c, f.name), set()).add(k)
            if ((k, c, p) in kept and c in staying and f.normal is not None
                    and satisfies(f.normal.guarantee(p), cat.conns[k].guarantee)):
                witnesses.setdefault(k, set()).add((c, f.name))
    # a connector some publisher that stays normal keeps satisfied (attached in the start and the
    # target) is satisfied in every configuration: its readers need not change for it
    found: set[FuncId] = set()
    todo: list[FuncId] = []
    touched: set[str] = set()

    def add(d: FuncId) -> None:
        if d not in found:
            found.add(d)
            todo.append(d)

    def touch(k: str) -> None:
        if k not in touched:
            touched.add(k)
            for d in readers.get(k, ()):
                add(d)

    for c in start.components ^ goal.components:
        for f in cat.comps[c].functionalities:
            add((c, f.name))
    for d in start.degraded | goal.degraded:
        if d[0] in start.components | goal.components:
            add(d)
    for k, _, _ in start.roles ^ goal.roles:
        touch(k)
    while todo:
        for k in outputs.get(todo.pop(), ()):
            if not witnesses.get(k, set()) - found:     # the last witness, if any, is relevant now
                touch(k)
    return frozenset(found)


class _Space:
    """The problem as the searches see it: what may change, and the bound on what is left."""

    def __init__(self, system: System, start: Configuration, goal: Goal, prune: bool = True) -> None:
        """With `prune` off, every functionality's mode is searched (to check `relevant` against)."""
        self.system, self.start, self.goal = system, start, goal
        self.cat: _Catalogue = catalogue(system)
        self.relevant = (relevant(system, start, goal) if prune else
                         frozenset((c, f.name) for c in start.components | goal.components
                                   for f in self.cat.comps[c].functionalities))
        self.by_comp: dict[str, list[FuncId]] = {}
        for d in sorted(self.relevant):
            self.by_comp.setdefault(d[0], []).append(d)
        self.arriving = sorted(goal.components - start.components)
        self.leaving = sorted(start.components - goal.components)
        self.wanted = sorted(goal.roles - start.roles)
        self.unwanted = sorted(start.roles - goal.roles)
        self.wanted_inputs = [r for r in self.wanted if not self.cat.is_output(r[1], r[2])]
        self.wanted_outputs = [r for r in self.wanted if self.cat.is_output(r[1], r[2])]
        self.weight = {d: f.criticality for d, f in self.cat.funcs.items()}

    # -- the lower bound on what is left --------------------------------------------------

    def bound(self, config: Configuration) -> tuple[int, int]:
        """(disruption, steps) that any plan from `config` still takes, at least."""
        goal, w, cat = self.goal, self.weight, self.cat
        if goal.reached(config):
            return 0, 0
        present = config.components
        st = Snapshot(cat, config)
        up = [d for d in config.degraded - goal.degraded if d[0] in present and d[0] in goal.components]
        # the heaviest that can be upgraded now may go first; every other waits a step at least
        ready = [w[d] for d in up if all(st.holds(d[0], cat.funcs[d], a) for a in _normal(cat.funcs[d]))]
        first = max(ready, default=0)
        rest = sorted((w[d] for d in up), reverse=True)
        if ready:
            rest.remove(first)
        cost = sum((i + 1) * x for i, x in enumerate(rest))
        down = sorted((w[d] for d in goal.degraded - config.degraded if d[0] in present), reverse=True)
        cost += sum((i + 1) * x for i, x in enumerate(down))
        cost += sum(w[d] for d in goal.degraded & config.degraded if d[0] in present)
        steps = len(config.roles ^ goal.roles) + len(present ^ goal.components) + len(up) + len(down)
        for c in goal.components - present:
            wanted_input = any(r[1] == c for r in self.wanted_inputs)
            for f in cat.comps[c].functionalities:
                d = (c, f.name)
                if d in goal.degraded:
                    cost += w[d]
                    continue
                # degraded after its creation, and after the attach its assumptions wait for
                cost += w[d] * (2 if wanted_input and self._needs_inputs(f) else 1)
                steps += 1
        for c in present - goal.components:
            attached = [r for r in config.roles if r[1] == c]
            inputs = {r[2] for r in attached if not cat.is_output(c, r[2])}
            for f in cat.comps[c].functionalities:
                d = (c, f.name)
                if not self._needs_inputs(f):
                    continue
                if d not in config.degraded:
                    # degraded before the last input it needs goes: in its own state and that detach's
                    cost += 2 * w[d]
                    steps += 1
                elif self._stuck(f, c, inputs):
                    cost += len(attached) * w[d]        # in the state after each detach c still needs
                elif inputs:
                    cost += min(len(attached), 2) * w[d]     # or upgraded, and degraded again later
        return cost, steps

    def _stuck(self, f: Functionality, c: str, inputs: set[str]) -> bool:
        """Whether `f` (of the leaving `c`) can never be normal again: an assumption of its normal
        mode that neither the environment nor any input of `c` still attached can give."""
        env = self.cat.env
        for a in _normal(f):
            if any(satisfies(e, a) for e in env):
                continue
            ports = [self.cat.ports[(c, p)] for p in f.ports if p in inputs]
            if not any(p.assumption is not None and satisfies(p.assumption, a) for p in ports):
                return True
        return False

    def _needs_inputs(self, f: Functionality) -> bool:
        """Whether some assumption of `f`'s normal mode is not given by the environment."""
        return f.normal is not None and any(not any(satisfies(e, a) for e in self.cat.env)
                                            for a in f.normal.assumptions)

    def distance(self, config: Configuration) -> int:
        """How far `config` seems from the goal, to order the reachability search (not a bound):
        the steps `bound` counts, and for each unwanted attachment whose detach is refused the
        functionalities it would degrade (`default._closure`), twice if they must come back."""

        st = Snapshot(self.cat, config)
        need: set[FuncId] = set()
        for r in self.unwanted:
            if r not in config.roles:
                continue
            a = Detach(*r)
            if check(st, a):
                suspects = {r[1]} | (st.readers([r[0]]) if st.is_output(r[1], r[2]) else set())
                need |= _closure(self.system, effect(self.system, config, a), suspects)
        need -= config.degraded
        return self.bound(config)[1] + sum(1 if d in self.goal.degraded else 2 for d in need)

    # -- the actions ------------------------------------------------------------------------

    def _modes(self, config: Configuration) -> Iterator[Action]:
        for c in sorted(config.components):
            for d in self.by_comp.get(c, ()):
                yield Upgrade(*d) if d in config.degraded else Degrade(*d)

    def moves(self, config: Configuration) -> list[Action]:
        """Every action of the space whose preconditions hold in `config` (A*)."""
        st = Snapshot(self.cat, config)
        acts: list[Action] = [Create(c) for c in self.arriving if c not in config.components]
        acts += [Remove(c) for c in self.leaving if c in config.components]
        acts += [Attach(*r) for r in self.wanted if r not in config.roles and r[1] in config.components]
        acts += [Detach(*r) for r in self.unwanted if r in config.roles]
        acts += list(self._modes(config))
        return [a for a in acts if not check(st, a)]

    def branches(self, config: Configuration) -> list[Action]:
        """The actions the reachability search branches on (the others are taken at once: `close`)."""
        st = Snapshot(self.cat, config)
        acts: list[Action] = [Attach(*r) for r in self.wanted_outputs
                              if r not in config.roles and r[1] in config.components]
        acts += [Detach(*r) for r in self.unwanted if r in config.roles]
        acts += list(self._modes(config))
        return [a for a in acts if not check(st, a)]

    def close(self, config: Configuration) -> tuple[Configuration, list[Action]]:
        """`config` after every step that never hurts (see the module docstring), and those steps."""
        steps: list[Action] = []
        while True:
            st = Snapshot(self.cat, config)
            attached = {c for _, c, _ in config.roles}
            todo: list[Action] = [Create(c) for c in self.arriving if c not in config.components]
            todo += [Attach(*r) for r in self.wanted_inputs if r not in config.roles and r[1] in config.components]
            todo += [Remove(c) for c in self.leaving if c in config.components and c not in attached]
            done = [a for a in todo if not check(st, a)]
            if not done:
                return config, steps
            for a in done:     # independent of one another: different components and roles
                config = effect(self.system, config, a)
            steps += done


def _normal(f: Functionality) -> tuple[Predicate, ...]:
    return f.normal.assumptions if f.normal is not None else ()


def _path(parent: dict[Configuration, tuple[Optional[Configuration], list[Action]]],
          end: Configuration) -> list[Action]:
    steps: list[Action] = []
    node: Optional[Configuration] = end
    while node is not None:
        prev, acts = parent[node]
        steps[:0] = acts
        node = prev
    return steps


def _reach(space: _Space, clock: _Clock) -> tuple[Optional[list[Action]], int, bool]:
    """Reachability: (a plan or None, configurations visited, whether the space was exhausted)."""
    first, pre = space.close(space.start)
    parent: dict[Configuration, tuple[Optional[Configuration], list[Action]]] = {first: (None, pre)}
    tie = count()
    frontier = [(space.distance(first), next(tie), first)]
    expanded = 0
    while frontier:
        _, _, config = heapq.heappop(frontier)
        if space.goal.reached(config):
            return _path(parent, config), len(parent), False
        expanded += 1
        if expanded % 64 == 1 and clock.over(len(parent)):
            return None, len(parent), False
        for a in space.branches(config):
            nxt, more = space.close(effect(space.system, config, a))
            if nxt in parent:
                continue
            parent[nxt] = (config, [a] + more)
            heapq.heappush(frontier, (space.distance(nxt), next(tie), nxt))
    return None, len(parent), True


def _astar(space: _Space, clock: _Clock, ceiling: Optional[tuple[int, int]],
           bound: Optional[Callable[[Configuration], tuple[int, int]]] = None) -> tuple[Optional[list[Action]], int]:
    """A*: the least disruptive plan (then the shortest), or None when the budget ran out
    (or no plan costs less than `ceiling`); and how many configurations it visited. `bound`
    replaces `space.bound` (a bound of (0, 0) makes it a uniform-cost search, to check the
    bound against)."""
    system, start, goal = space.system, space.start, space.goal
    bound = bound or space.bound
    best: dict[Configuration, tuple[int, int]] = {start: (0, 0)}
    parent: dict[Configuration, tuple[Optional[Configuration], list[Action]]] = {start: (None, [])}
    tie = count()
    h = bound(start)
    frontier = [(h[0], h[1], 0, next(tie), (0, 0), start)]
    expanded = 0
    while frontier:
        _, _, _, _, g, config = heapq.heappop(frontier)
        if g != best[config]:
            continue
        if goal.reached(config):
            return _path(parent, config), len(best)
        expanded += 1
        if expanded % 64 == 1 and clock.over(clock.visited + len(best)):
            return None, len(best)
        for a in space.moves(config):
            nxt = effect(system, config, a)
            cost = (g[0] + state_weight(system, nxt), g[1] + 1)
            old = best.get(nxt)
            if old is not None and old <= cost:
                continue
            hn = bound(nxt)
            est = (cost[0] + hn[0], cost[1] + hn[1])
            if ceiling is not None and est > ceiling:
                continue
            best[nxt] = cost
            parent[nxt] = (config, [a])
            heapq.heappush(frontier, (est[0], est[1], -cost[1], next(tie), cost, nxt))
    return None, len(best)


def exhaustive_search(system: System, start: Configuration, goal: Goal, budget: Budget = Budget(),
                      incumbent: Optional[list[Action]] = None) -> Search:
    """Decide whether a plan exists and find the least disruptive one the budget allows (see the
    module docstring). Raises NoSafePlan, saying how it knows, when none exists, and
    SearchTooLarge when the budget ran out first.

    `incumbent`, a plan found otherwise (the default strategy's): where it reaches the goal, a
    plan exists, so the reachability search is skipped, and A* looks only for plans at most as
    disruptive; what is returned is never worse than it."""
    known = None if incumbent is None else cost(system, start, incumbent, goal)
    if incumbent is not None and known is not None:
        return _beat(system, start, goal, budget, incumbent, known)
    clock = _Clock(budget)
    space = _Space(system, start, goal)
    for restricted in (False, True):
        relaxation = reachable(system, start, goal, restricted, space.relevant, clock.deadline)
        if not relaxation.possible:
            raise Impossible([_impossible(relaxation, restricted)], "relaxation")
    found, visited, exhausted = _reach(space, clock)
    if found is None:
        if exhausted:
            raise Impossible([f"exhaustive: no safe plan exists: the search visited all {visited:,} configurations "
                              "reachable from the start by safe steps towards the target (each attachment and "
                              "component changed at most once, the modes of the "
                              f"{plural(len(space.relevant), 'functionality', 'functionalities')} the change can "
                              "affect), and none is the target"], "search")
        raise SearchTooLarge([f"exhaustive: gave up after visiting {visited:,} configurations in "
                              f"{clock.spent():.0f} s without deciding whether a plan exists"])
    clock.visited = visited
    steps, optimised = _astar(space, clock, cost(system, start, found, goal))
    if steps is not None:
        return Search(steps, True, visited, optimised, clock.spent())
    return Search(improve(system, start, found, goal), False, visited, optimised, clock.spent())


def _beat(system: System, start: Configuration, goal: Goal, budget: Budget, incumbent: list[Action],
          known: tuple[int, int]) -> Search:
    """A* for a plan at most as disruptive as `incumbent` (whose cost is `known`); else it."""
    clock = _Clock(budget)
    steps, optimised = _astar(_Space(system, start, goal), clock, known)
    if steps is not None:
        better = cost(system, start, steps, goal)
        if better is not None and better <= known:
            return Search(steps, True, 0, optimised, clock.spent(), incumbent=known)
    return Search(incumbent, False, 0, optimised, clock.spent(), incumbent=known, kept=True,
                  over=clock.over(clock.visited + optimised))


def _impossible(relaxation: Relaxation, restricted: bool) -> str:
    """Why no plan exists, as the relaxation proved it."""
    scope = ("steps towards the target (each attachment and component changed at most once)" if restricted else
             "the components and attachments of the start and the target, each changed any number of times")
    shown = relaxation.missing[:4]
    more = len(relaxation.missing) - len(shown)
    return (f"exhaustive: no safe plan exists: {'; '.join(shown)}" + (f" (and {more} more)" if more > 0 else "")
            + f". Proved by relaxing the search (every step that could ever be safe taken at once, nothing ever "
            f"undone) over {scope}")


def exhaustive_steps(system: System, start: Configuration, goal: Goal, budget: Budget = Budget()) -> list[Action]:
    """The steps of `exhaustive_search`."""
    return exhaustive_search(system, start, goal, budget).steps
