"""The `default` strategy: make before break, degrade only what really loses its inputs.

A loop over the current configuration. Each turn takes the first *free* action, one that
moves towards the goal without degrading anything, in this order:

1. upgrade a degraded functionality whose normal assumptions hold (most critical first),
   unless the goal keeps it degraded;
2. attach a wanted input of a component that has degraded functionalities;
3. attach a wanted output (a `single` connector refuses it while the old publisher is on);
4. attach any other wanted input;
5. create an arriving component (one whose inputs are already served first);
6. detach an unwanted attachment that nothing needs any more, remove an isolated leaving
   component.

(The loop also runs with 5 and 6 swapped, and the less disruptive result, after local
improvement (`improve`), is kept: cleaning up first sometimes frees a `single` connector
sooner; creating first keeps an old publisher that a new component needs to start.)

When no free action is left, the detach that degrades the least is chosen. Why this keeps
nobody degraded that need not be, and why the loop terminates:
docs/soundness.md#the-default-strategy.
"""
from __future__ import annotations

import heapq
from typing import Optional

from checker.planning.improve import cost, improve
from checker.planning.plan import Goal, NoSafePlan
from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Snapshot,
    Upgrade,
    catalogue,
    check,
    effect,
)
from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.ir import System

__all__ = ["default_steps"]


def default_steps(system: System, start: Configuration, goal: Goal) -> list[Action]:
    """The better of two orders of free actions (creating before or after cleaning up), improved."""
    plans, reasons = [], []
    for make_first in (True, False):
        try:
            steps = improve(system, start, _loop(system, start, goal, make_first), goal)
        except NoSafePlan as e:
            reasons += [r for r in e.reasons if r not in reasons]
            continue
        c = cost(system, start, steps, goal)
        assert c is not None
        plans.append((c, steps))
    if not plans:
        raise NoSafePlan(reasons)
    return min(plans, key=lambda p: p[0])[1]


def _loop(system: System, start: Configuration, goal: Goal, make_first: bool) -> list[Action]:
    cat = catalogue(system)
    config = start
    steps: list[Action] = []
    limit = 10 * (len(start.roles | goal.roles) + len(start.components | goal.components)
                  + len(cat.funcs)) + 20
    # Upgrades refused in an earlier turn, kept until a step touches what they depend on
    # (see _touched): without it every turn re-tries every degraded functionality, and a
    # plan of thousands of degrades would take quadratic time.
    blocked: set[FuncId] = set()
    # The degraded functionalities to try upgrading, as a heap in upgrade order (entries
    # may be stale: _free skips what is no longer degraded or is blocked).
    rank = _upgrade_order(system)
    pool = [(rank[d], d) for d in start.degraded if d in rank]
    heapq.heapify(pool)
    for _ in range(limit):
        if goal.reached(config):
            return steps
        action = _free(system, config, goal, make_first, blocked, pool)
        macro = [action] if action is not None else _unblock(system, config, goal)
        for a in macro:
            st = Snapshot(cat, config)
            reasons = check(st, a)
            assert not reasons, (a, reasons)
            steps.append(a)
            touched = _touched(st, a)
            after = effect(system, config, a)
            for d in after.degraded - config.degraded if isinstance(a, (Degrade, Create)) else ():
                heapq.heappush(pool, (rank[d], d))
            config = after
            released = {d for d in blocked if d[0] in touched}
            if released:
                blocked -= released
                for d in released:
                    heapq.heappush(pool, (rank[d], d))
    raise NoSafePlan(["default: no progress (internal limit reached)"])


def _touched(st: Snapshot, a: Action) -> set[str]:
    """The components whose upgrades `a` (applied in `st`) can make possible or impossible:
    an upgrade of f reads f's component (present, f's mode) and the satisfaction of the
    connectors its inputs are attached to, which changes only when a publisher on one of
    them is attached, detached, degraded or upgraded."""
    comp = getattr(a, "component")
    out = {comp}
    if isinstance(a, (Attach, Detach)):
        out |= st.readers([a.connector])
    elif isinstance(a, (Degrade, Upgrade)):
        out |= st.readers(k for k, _ in st.attached_outputs(comp))
    return out


def _weight(system: System, fid: FuncId) -> int:
    return catalogue(system).funcs[fid].criticality


_ORDER: dict[int, tuple[System, dict[FuncId, int]]] = {}


def _upgrade_order(system: System) -> dict[FuncId, int]:
    """Upgrades are tried most critical first, then by name: each functionality's rank in
    that order, made once per system (sorting by a key built per call dominated long plans)."""
    hit = _ORDER.get(id(system))
    if hit is None or hit[0] is not system:
        if len(_ORDER) > 16:
            _ORDER.clear()
        funcs = catalogue(system).funcs
        order = sorted(funcs, key=lambda d: (-funcs[d].criticality, d))
        hit = _ORDER[id(system)] = (system, {d: i for i, d in enumerate(order)})
    return hit[1]


def _free(system: System, config: Configuration, goal: Goal, make_first: bool,
          blocked: set[FuncId], pool: list[tuple[int, FuncId]]) -> Optional[Action]:
    """The next action that needs nothing degraded first: the most critical upgrade that
    holds, else an attach, else a create or a clean-up step. `blocked` and `pool` carry
    what earlier turns learnt (see _loop), and are updated here."""
    cat = catalogue(system)
    st = Snapshot(cat, config)
    aside = []
    found: Optional[Action] = None
    while pool:
        item = heapq.heappop(pool)
        d = item[1]
        if d not in config.degraded or d in goal.degraded or d in blocked:
            continue
        if d[0] not in config.components:
            aside.append(item)
            continue
        if not check(st, Upgrade(*d)):
            found = Upgrade(*d)
            break
        blocked.add(d)
    for item in aside:
        heapq.heappush(pool, item)
    if found is not None:
        return found
    wanted = sorted(r for r in goal.roles - config.roles if r[1] in config.components)
    hurting = {c for c, _ in config.degraded}
    groups = [[r for r in wanted if not st.is_output(r[1], r[2]) and r[1] in hurting],
              [r for r in wanted if st.is_output(r[1], r[2])],
              [r for r in wanted if not st.is_output(r[1], r[2])]]
    for group in groups:
        for conn, c, p in group:
            if not check(st, Attach(conn, c, p)):
                return Attach(conn, c, p)
    arriving = sorted(goal.components - config.components, key=lambda c: (_unserved(st, goal, c), c))
    creates: list[Action] = [Create(c) for c in arriving]
    unwanted = sorted(config.roles - goal.roles, key=lambda r: (not st.is_output(r[1], r[2]), r))
    cleanup: list[Action] = [Detach(*r) for r in unwanted]
    cleanup += [Remove(c) for c in sorted(config.components - goal.components)]
    for a in (creates + cleanup if make_first else cleanup + creates):
        if not check(st, a):
            return a
    return None


def _unserved(st: Snapshot, goal: Goal, comp: str) -> int:
    """How many of the wanted inputs of `comp` read an unsatisfied connector."""
    return sum(1 for conn, c, p in goal.roles
               if c == comp and not st.is_output(c, p) and not st.conn_sat(conn))


def _closure(system: System, config: Configuration, suspects: Optional[set[str]] = None) -> set[FuncId]:
    """The functionalities that must be degraded for `config` to be valid, grown to a fixpoint.

    With `suspects`, `config` is one step away from a valid configuration and only those
    components can have lost an assumption; then only the readers of what each round
    degrades are looked at next (nothing else can change)."""
    cat = catalogue(system)
    extra: set[FuncId] = set()
    look = set(suspects) if suspects is not None else set(config.components)
    while True:
        trial = Configuration(config.components, config.degraded | extra, config.roles)
        st = Snapshot(cat, trial)
        failing = {(c, f) for c, f, _ in st.unsafe(look & trial.components & set(cat.comps))} - extra
        if not failing:
            return extra
        extra |= failing
        if suspects is not None:
            look = st.readers({conn for d in failing for p in cat.funcs[d].ports if st.is_output(d[0], p)
                               for conn in st.by_port.get((d[0], p), [])})


def _order(system: System, config: Configuration, todo: set[FuncId]) -> Optional[list[Action]]:
    """Degrade `todo` one by one, least critical first among those whose preconditions hold.

    Those that publish to a reader still in `todo` are tried after the others (their degrade
    would be refused until that reader is degraded), so a long closure is ordered in about
    linear time instead of by trying everything at every step."""
    cat = catalogue(system)
    st = Snapshot(cat, config)
    by_comp: dict[str, set[FuncId]] = {}
    for d in todo:
        by_comp.setdefault(d[0], set()).add(d)
    waits: dict[FuncId, set[FuncId]] = {}
    for d in todo:
        conns = {conn for p in cat.funcs[d].ports if st.is_output(d[0], p) for conn in st.by_port.get((d[0], p), [])}
        waits[d] = {g for r in st.readers(conns) for g in by_comp.get(r, ())} - {d}
    feeds: dict[FuncId, set[FuncId]] = {d: set() for d in todo}
    for d, ws in waits.items():
        for g in ws:
            feeds[g].add(d)
    pending = {d: len(ws) for d, ws in waits.items()}
    ready = [(_weight(system, d), d) for d in todo if not pending[d]]
    heapq.heapify(ready)
    out: list[Action] = []
    left = set(todo)
    while left:
        st = Snapshot(cat, config)
        first: Optional[FuncId] = None
        refused = []
        while ready:
            item = heapq.heappop(ready)
            if item[1] not in left:
                continue
            if not check(st, Degrade(*item[1])):
                first = item[1]
                break
            refused.append(item)
        for item in refused:
            heapq.heappush(ready, item)
        if first is None:
            first = next((d for d in sorted(left, key=lambda d: (_weight(system, d), d))
                          if not check(st, Degrade(*d))), None)
            if first is None:
                return None
        a = Degrade(*first)
        out.append(a)
        config = effect(system, config, a)
        left.discard(first)
        for e in feeds[first]:
            pending[e] -= 1
            if not pending[e] and e in left:
                heapq.heappush(ready, (_weight(system, e), e))
    return out


def _unblock(system: System, config: Configuration, goal: Goal) -> list[Action]:
    cat = catalogue(system)
    best: Optional[tuple[tuple[int, int, int], list[Action]]] = None
    reasons: list[str] = []
    for conn, c, p in sorted(config.roles - goal.roles):
        detach = Detach(conn, c, p)
        st = Snapshot(cat, config)
        suspects = {c} | (st.readers([conn]) if st.is_output(c, p) else set())
        todo = _closure(system, effect(system, config, detach), suspects)
        degrades = _order(system, config, todo)
        if degrades is None:
            reasons.append(f"{detach.describe()} needs {', '.join(f'{x}.{y}' for x, y in sorted(todo))} degraded "
                           "first, and no order of degrades is safe")
            continue
        after = config
        for a in degrades:
            after = effect(system, after, a)
        if check(Snapshot(cat, after), detach):
            continue
        # A leaving component's own inputs go last: what they degrade stays degraded until removal.
        leaving_input = c not in goal.components and not Snapshot(cat, config).is_output(c, p)
        key = (int(leaving_input), sum(_weight(system, d) for d in todo), len(todo))
        if best is None or key < best[0]:
            best = (key, degrades + [detach])
    if best is None:
        # What must end degraded and is not yet (no detach needed it): degrade it now.
        left = {d for d in goal.degraded - config.degraded if d[0] in config.components}
        degrades = _order(system, config, left) if left else None
        if degrades:
            return degrades
        raise NoSafePlan(reasons or _stuck(system, config, goal))
    return best[1]


def _stuck(system: System, config: Configuration, goal: Goal) -> list[str]:
    """Why nothing can move: what each missing step is refused for."""
    st = Snapshot(catalogue(system), config)
    out = []
    for conn, c, p in sorted(goal.roles - config.roles):
        if c in config.components:
            out += [f"cannot attach {c}.{p} to {conn}: {r}" for r in check(st, Attach(conn, c, p))]
    for c, f in sorted(config.degraded - goal.degraded):
        if c in goal.components and c in config.components:
            out += [f"cannot upgrade {c}.{f}: {r}" for r in check(st, Upgrade(c, f))]
    return out or ["default: no action makes progress"]
