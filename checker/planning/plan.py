"""Plans, goals, disruption and the step-by-step check every plan passes before it is returned.

Disruption (one function, `disruption`): for a plan with states s0 (before the first step)
… sn (after the last), disruption = Σ_{i=1..n} weight(s_i), where weight(s) is the sum of the
criticality of every functionality that is degraded in s and belongs to a component present
in s. Functionalities of absent components do not count; a freshly created component counts
until its functionalities are upgraded. So a functionality of criticality w that stays
degraded for k steps costs w·k, and the empty plan costs 0.
"""
from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from itertools import pairwise
from typing import Any, Iterable, Optional, Sequence

from checker.planning.durations import Degradation, Durations, degraded_seconds, durations
from checker.planning.states import States
from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Detach,
    Remove,
    Snapshot,
    _Catalogue,
    catalogue,
    effect,
    failing_assumptions,
    form_refusals,
    preconditions,
    satisfies,
)
from checker.semantic_model.config import Configuration, FuncId, Role
from checker.semantic_model.semantics import evaluate
from reconf_dsl.ir import System
from reconf_dsl.words import plural

__all__ = ["Goal", "Plan", "Problem", "Recovery", "NoSafePlan", "BadRequest", "unknown", "settle", "disruption", "state_weight", "run_actions", "verify",
           "FULL_CHECK_LIMIT", "state_dict", "state_change",
           "degradation", "degraded_runs"]


class BadRequest(ValueError):
    """The change asked for is ill-posed (a component that is not there, a replacement that is
    not a new version): the user's mistake, reported as such, not as an unsafe change."""


def unknown(kind: str, name: str, known: Iterable[str], where: str) -> BadRequest:
    """`name` is not a `kind` of `where`, with the closest known names."""
    close = difflib.get_close_matches(name, sorted(known), n=3)
    hint = f" (did you mean {' or '.join(close)}?)" if close else ""
    return BadRequest(f"{name} is not a {kind} of {where}{hint}")


class NoSafePlan(Exception):
    """No plan keeps every step valid; `reasons` says why."""

    def __init__(self, reasons: list[str]) -> None:
        super().__init__("no safe plan: " + "; ".join(reasons))
        self.reasons = reasons


@dataclass(frozen=True)
class Goal:
    """A target configuration: these components present, exactly these attachments, and exactly
    the functionalities of `degraded` degraded (residual degradation: those whose assumptions
    cannot hold in the target, see `settle`); `why` says, per degraded one, what cannot hold."""

    components: frozenset[str]
    roles: frozenset[Role]
    degraded: frozenset[FuncId] = frozenset()
    why: tuple[tuple[FuncId, str], ...] = ()

    def reached(self, config: Configuration) -> bool:
        return (config.components == self.components and config.roles == self.roles
                and config.degraded == self.degraded)

    @property
    def config(self) -> Configuration:
        return Configuration(self.components, self.degraded, self.roles)

    def residual_notes(self) -> list[str]:
        """One line per functionality that stays degraded, and why."""
        return [f"{c}.{f} stays degraded: {reason}" for (c, f), reason in self.why]


def settle(system: System, goal: Goal) -> Goal:
    """`goal` with the least set D of degraded functionalities such that the target is valid.

    Starting from `goal.degraded`, every functionality one of whose current assumptions fails is
    degraded, and the check is repeated (a degraded functionality may stop satisfying a
    connector others read), until nothing fails. D only grows and degraded modes assume
    nothing, so this terminates with a valid configuration; every functionality in D had to
    be degraded given the ones before it, so D is the least such set."""
    degraded = set(goal.degraded)
    why = dict(goal.why)
    while True:
        failing = failing_assumptions(system, Configuration(goal.components, frozenset(degraded), goal.roles))
        new = [(c, f, a) for c, f, a in failing if (c, f) not in degraded]
        if not new:
            break
        for c, f, a in new:
            if (c, f) not in why:
                why[(c, f)] = f"it assumes {a}, which cannot hold in the target"
            degraded.add((c, f))
    return Goal(goal.components, goal.roles, frozenset(degraded),
                tuple(sorted((d, w) for d, w in why.items() if d in degraded)))


_WEIGHTS: dict[tuple[int, int, int], tuple[System, frozenset[str], frozenset[FuncId], int]] = {}


def state_weight(system: System, config: Configuration) -> int:
    """Memoised by identity of the sets: consecutive states mostly share them."""
    key = (id(system), id(config.components), id(config.degraded))
    hit = _WEIGHTS.get(key)
    if hit is not None and hit[0] is system and hit[1] is config.components and hit[2] is config.degraded:
        return hit[3]
    funcs = catalogue(system).funcs
    w = sum(funcs[d].criticality for d in config.degraded if d[0] in config.components and d in funcs)
    if len(_WEIGHTS) > 512:
        _WEIGHTS.clear()
    _WEIGHTS[key] = (system, config.components, config.degraded, w)
    return w


def next_weight(system: System, before: Configuration, weight: int, action: Any, after: Configuration) -> int:
    """`state_weight(system, after)` from `weight`, the weight of `before`, and the action
    between them: only what the action changes is counted (a degrade or upgrade changes
    one functionality, a create or remove one component's), so a long plan is weighed in
    time linear in its length rather than in length times degradation."""
    cat = catalogue(system)
    funcs = cat.funcs
    kind = getattr(action, "kind", "")
    if kind in ("attach", "detach"):
        return weight
    c = getattr(action, "component", None)
    comp = cat.comps.get(c) if c is not None else None
    if comp is None or kind not in ("degrade", "upgrade", "create", "remove"):
        return state_weight(system, after)

    def part(config: Configuration) -> int:
        if c not in config.components:
            return 0
        return sum(funcs[(c, f.name)].criticality for f in comp.functionalities if (c, f.name) in config.degraded)

    return weight - part(before) + part(after)


def disruption(system: System, states: Sequence[Configuration], steps: Optional[Sequence[Any]] = None) -> int:
    """Σ over the states after each step of the criticality of its degraded functionalities
    (weighed step by step when the steps between the states are given)."""
    if steps is None or len(steps) != len(states) - 1 or not states:
        return sum(state_weight(system, s) for s in states[1:])
    total, weight = 0, state_weight(system, states[0])
    for before, a, after in zip(states, steps, states[1:]):
        weight = next_weight(system, before, weight, a, after)
        total += weight
    return total


@dataclass
class Plan:
    system: System
    steps: list[Action]
    states: Sequence[Configuration]     # a `States` for a verified plan: see checker.planning.states
    strategy: str
    disruption: int
    goal: Goal
    renames: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    verification: str = "full"      # "full": every state evaluated; "local": see `verify`
    # (connector, proxy component) pairs that must serve their clients in every state: the
    # proxy stays in its normal mode and the connector satisfied, so no request is lost
    # (FTM transitions: a suspended protocol queues requests, see checker.ftm.transition)
    serving: list[tuple[str, str]] = field(default_factory=list)
    # connectors that must stay satisfied in every state: a lean slice leaves out their
    # readers on that ground (see checker.planning.slicing), and Alloy must prove it
    stable: list[str] = field(default_factory=list)
    # (proxy, protocol): the protocols a `serving` or `handover` proxy's requests must reach,
    # through the readers of what it publishes (a suspended protocol queues them)
    protocols: list[tuple[str, str]] = field(default_factory=list)
    # (connector, proxy) pairs of servers losing or gaining their FTM: while the proxy
    # publishes on its clients' connector it stays normal and its requests reach a protocol
    handover: list[tuple[str, str]] = field(default_factory=list)
    # the strategies tried before the one that produced this plan, and why they failed
    # (checker.planning.chain)
    attempts: list["Attempt"] = field(default_factory=list)
    # a recovery's plan (checker.planning.recovery): from an observed configuration that may
    # not be valid, its first steps degrade what fails; None for every other plan
    recovery: Optional["Recovery"] = None
    # how long each action takes (checker.planning.durations); None: the system's own
    times: Optional[Durations] = None
    # runs of steps carried out together, (first, last) from 1, each proved safe in every
    # order its steps can complete in (checker.planning.batches)
    batches: list[tuple[int, int]] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.steps)

    def describe(self) -> list[str]:
        return [f"{i:>3}. {a.symbol} {a.describe()}" for i, a in enumerate(self.steps, 1)]

    def summary(self) -> str:
        counts: dict[str, int] = {}
        for a in self.steps:
            counts[a.kind] = counts.get(a.kind, 0) + 1
        parts = ", ".join(f"{n} {k}" for k, n in counts.items()) or "nothing to do"
        left = ""
        if self.goal.degraded:
            left = "; left degraded: " + ", ".join(f"{c}.{f}" for c, f in sorted(self.goal.degraded))
        sec = self.seconds()
        return (f"{plural(len(self.steps), 'step')} ({parts}); disruption {self.disruption}; "
                f"~{sec.weighted:.2f} s degraded in ~{sec.total:.1f} s; strategy {self.strategy}{left}")

    def durations(self) -> Durations:
        return self.times if self.times is not None else durations(self.system)

    def seconds(self) -> Degradation:
        """The plan's expected seconds on the wire, and degraded (checker.planning.durations)."""
        return degraded_seconds(self.system, self.states[0], self.steps, self.durations(), self.batches)

    def to_dict(self) -> dict[str, Any]:
        """The plan as data: its first state in full and, per step, what the step changed (states
        as deltas, so the document grows with the plan's length, not length × size)."""
        out: dict[str, Any] = {
            "strategy": self.strategy, "disruption": self.disruption,
            "seconds": dict(self.seconds().to_dict(), durations=self.durations().to_dict()),
            "steps": [a.to_dict() for a in self.steps],
            "start": state_dict(self.states[0]),
            "changes": [state_change(before, after) for before, after in pairwise(self.states)],
            "renames": dict(self.renames), "notes": list(self.notes), "verification": self.verification,
            "left_degraded": [{"component": c, "functionality": f, "why": w} for (c, f), w in self.goal.why]}
        if self.batches:
            out["batches"] = [list(b) for b in self.batches]
        if self.attempts:
            out["attempts"] = [a.to_dict() for a in self.attempts]
        if self.recovery is not None:
            out["recovery"] = self.recovery.to_dict()
        return out


@dataclass
class Recovery:
    """What a recovery's plan adds to a plan (docs/executor.md#failure-and-recovery): its first
    `restore` steps degrade what fails in the observed configuration, judged by the property
    docs/soundness.md proves (#restoring-validity), and `rest` is the ordinary plan from there
    (what Alloy verifies, as any plan); `placed` the nodes the live system showed for
    components not under their own names; `orphans` the nodes a plan started that are in no
    configuration (unconfigured or inactive), ended before the first step."""

    restore: int = 0
    rest: Optional["Plan"] = None
    placed: dict[str, str] = field(default_factory=dict)
    orphans: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"restore": self.restore, "placed": dict(sorted(self.placed.items())),
                "orphans": [dict(o) for o in self.orphans]}


def state_dict(s: Configuration) -> dict[str, list[Any]]:
    """A configuration as data, each part sorted."""
    return {"components": sorted(s.components), "degraded": [list(d) for d in sorted(s.degraded)],
            "roles": [list(r) for r in sorted(s.roles)]}


def state_change(before: Configuration, after: Configuration) -> dict[str, dict[str, list[Any]]]:
    """What `after` adds to `before` and drops from it, part by part (empty parts left out)."""
    change: dict[str, dict[str, list[Any]]] = {}
    for part in ("components", "degraded", "roles"):
        b, a = getattr(before, part), getattr(after, part)
        if a is b:
            continue
        for key, items in (("add", a - b), ("drop", b - a)):
            if items:
                change.setdefault(key, {})[part] = sorted(list(x) if isinstance(x, tuple) else x for x in items)
    return change


def degraded_runs(plan: Plan) -> dict[FuncId, list[range]]:
    """Per functionality, the runs of states (indices 1…n, after each step) in which it is degraded
    and its component present: read from the steps (a step changes the functionalities of one
    component), in time linear in the plan."""
    comps = catalogue(plan.system).comps
    runs: dict[FuncId, list[range]] = {}
    since: dict[FuncId, int] = {}       # degraded (and present) from this state on

    def close(fid: FuncId, i: int) -> None:
        runs.setdefault(fid, []).append(range(since.pop(fid), i))

    first = plan.states[0]
    since.update(((c, f), 1) for c, f in first.degraded if c in first.components)
    for i, ((before, after), a) in enumerate(zip(pairwise(plan.states), plan.steps), 1):
        comp = comps.get(getattr(a, "component", ""))
        if comp is None or a.kind in ("attach", "detach"):
            continue
        for f in comp.functionalities:
            fid = (comp.name, f.name)
            was = fid in before.degraded and comp.name in before.components
            now = fid in after.degraded and comp.name in after.components
            if now and not was:
                since[fid] = i
            elif was and not now:
                close(fid, i)
    for fid in list(since):
        close(fid, len(plan.states))
    return runs


def degradation(plan: Plan) -> dict[str, Any]:
    """Which functionalities were degraded, for how many steps, and the longest run."""
    runs = {f"{c}.{f}": r for (c, f), r in degraded_runs(plan).items()}
    steps = {name: sum(map(len, r)) for name, r in runs.items()}
    longest = {name: max(map(len, r)) for name, r in runs.items()}
    return {"functionalities": dict(sorted(steps.items())), "longest": max(longest.values(), default=0),
            "longest_functionality": max(longest, key=lambda k: (longest[k], k)) if longest else None}


def run_actions(system: System, start: Configuration, steps: Sequence[Action]) -> Sequence[Configuration]:
    """The states s0…sn of `steps` from `start` (preconditions not checked)."""
    return States(system, start, steps)


FULL_CHECK_LIMIT = 10_000
"""States × components up to which `verify` re-evaluates every state in full by default."""


def verify(system: System, start: Configuration, steps: Sequence[Action], goal: Goal, strategy: str,
           renames: dict[str, str] | None = None, full: Optional[bool] = None) -> Plan:
    """Re-check a plan step by step: every precondition holds, every state is valid, the goal is reached.

    With `full` (the default when states × components ≤ FULL_CHECK_LIMIT) every state is judged
    by `semantics.evaluate`, the engine the planners do not use. Otherwise the last state is,
    and each intermediate state is re-checked where its step can change anything: the
    functionalities of the component the step touches and of every reader of a connector
    whose satisfaction it changes (an assumption depends only on those). The
    plan's `verification` says which was done."""
    cat = catalogue(system)
    try:
        malformed = [str(r) for r in form_refusals(system, start)]
    except ValueError as e:
        malformed = [str(e)]
    if malformed:
        raise NoSafePlan([f"{strategy}: the initial configuration is not well formed: " + "; ".join(malformed)])
    if full is None:
        full = (len(steps) + 1) * max(1, len(start.components)) <= FULL_CHECK_LIMIT
    kept, before = {0: start}, start
    total, weight = 0, state_weight(system, start)
    for i, a in enumerate(steps, 1):
        reasons = preconditions(system, before, a)
        if reasons:
            raise NoSafePlan([f"{strategy}: step {i} ({a.describe()}) is refused: " + "; ".join(reasons)])
        after = effect(system, before, a)
        if full or i == len(steps):
            failing = [(r.component, r.functionality, r.assumption)
                       for r in evaluate(system, after, explain=False).unsatisfied]
        else:
            failing = Snapshot(cat, after).unsafe(_touched(cat, before, after, a))
        if failing:
            c, f, asm = failing[0]
            raise NoSafePlan([f"{strategy}: after step {i} ({a.describe()}) {c}.{f} assumes {asm}, which fails"])
        weight = next_weight(system, before, weight, a, after)
        total += weight
        if States.keep(i, len(steps)):
            kept[i] = after
        before = after
    if not goal.reached(before):
        raise NoSafePlan([f"{strategy}: the plan does not reach the goal"])
    notes = goal.residual_notes()
    if not full:
        notes.append(f"verification: the last state judged in full; the {plural(len(steps) - 1, 'intermediate state')} "
                     "re-checked where each step can change them (a full re-evaluation of every state is "
                     f"beyond {FULL_CHECK_LIMIT:,} states × components)")
    return Plan(system, list(steps), States(system, start, steps, kept), strategy, total, goal, dict(renames or {}),
                notes, "full" if full else "local")


def _touched(cat: _Catalogue, before: Configuration, after: Configuration, a: Action) -> set[str]:
    """The present components whose assumptions `a` can make fail: the one it touches, and the
    readers of each connector whose satisfaction it changes (an input assumption depends only
    on the satisfaction of the connectors its port is attached to)."""
    if isinstance(a, Remove):
        return set()          # an isolated component: nothing reads it
    if isinstance(a, Create):
        return {a.component}
    s0, s1 = Snapshot(cat, before), Snapshot(cat, after)
    if isinstance(a, (Attach, Detach)):
        conns = [a.connector] if a.connector in cat.conns else []
    else:
        outs = [(a.component, p) for p in cat.funcs[(a.component, a.functionality)].ports]
        conns = sorted({conn for o in outs for conn in s1.by_port.get(o, [])})
    changed = [conn for conn in conns if s0.conn_sat(conn) != s1.conn_sat(conn)]
    return ({a.component} | s0.readers(changed) | s1.readers(changed)) & after.components


@dataclass
class Problem:
    """A reconfiguration to plan: where from, where to, and what changes (for the `paper` strategy,
    which reasons per component)."""

    system: System
    start: Configuration
    goal: Goal
    replaced: list[tuple[str, str]] = field(default_factory=list)   # (old, new)
    removed: list[str] = field(default_factory=list)
    added: list[str] = field(default_factory=list)
    renames: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Attempt:
    """A strategy that gave no accepted plan: `outcome` is "no plan" (it found none), "none
    exists" (it proved that no plan exists, by `how`: "relaxation" or "search"), "gave up" (its
    budget ran out), "refuted" (the caller refused its plan) or "unavailable"; `reasons` say
    why."""

    strategy: str
    outcome: str
    reasons: tuple[str, ...]
    how: str = ""

    def describe(self) -> str:
        said = "; ".join(r.removeprefix(f"{self.strategy}: ") for r in self.reasons)
        if self.outcome == "no plan":
            said = "found no plan" + (f": {said}" if said else "")
        elif self.outcome == "unavailable":
            said = "unavailable" + (f": {said}" if said else "")
        return f"{self.strategy}: {said or self.outcome}"

    def to_dict(self) -> dict[str, object]:
        out: dict[str, object] = {"strategy": self.strategy, "outcome": self.outcome, "reasons": list(self.reasons)}
        if self.how:
            out["proved_by"] = self.how
        return out


def ready(problem: Problem) -> Problem:
    """Refuse an invalid start or an impossible target; the problem with its goal `settle`d."""
    s, cat = problem.system, catalogue(problem.system)
    bad = failing_assumptions(s, problem.start)
    if bad:
        raise NoSafePlan([f"the current configuration is not valid: {c}.{f} assumes {a}, which does not hold"
                          for c, f, a in bad])
    reasons = [f"the target needs {c}, which is not declared" for c in sorted(problem.goal.components)
               if c not in cat.comps]
    if reasons:
        raise NoSafePlan(reasons)
    pubs: dict[str, list[str]] = {}
    short: list[str] = []
    for n, c, p in problem.goal.roles:
        port = cat.comps[c].port(p)
        if port is None or port.kind != "output" or n not in cat.conns:
            continue
        pubs.setdefault(n, []).append(f"{c}.{p}")
        want = cat.conns[n].guarantee
        best = [f.normal.guarantee(p) for f in cat.comps[c].functionalities if p in f.ports and f.normal]
        if not any(satisfies(g, want) for g in best):
            short.append(f"{c}.{p} guarantees at best {' or '.join(map(str, best)) or 'nothing'}, which does not "
                         f"satisfy {want} of {n}")
    for conn in s.connectors:
        if conn.single_publisher and len(pubs.get(conn.name, [])) > 1:
            reasons.append(f"in the target, {conn.name} takes a single publisher but has "
                           f"{', '.join(sorted(pubs[conn.name]))}")
    if reasons:
        raise NoSafePlan(reasons)
    goal = settle(s, problem.goal)
    if short and goal.degraded:
        # A publisher that can never serve its topic is a mistake in the target, not a degradation to plan.
        said = [w.removeprefix("it ").replace("cannot hold in the target", "would not hold") for _, w in goal.why]
        raise NoSafePlan([f"in the target, {c}.{f} {w}" for ((c, f), _), w in zip(goal.why, said)]
                         + [f"in the target, {x}" for x in sorted(short)])
    return dc_replace(problem, goal=goal)
