"""Plans as partial orders: runs of consecutive steps that the executor carries out together
(docs/soundness.md#batches).

A *batch* is a run of consecutive steps of a verified plan on pairwise distinct components. Run
together, its steps may complete in any order, so the system may pass through the state before
the batch with any subset of its steps done. A batch is allowed only when every such state and
every move between two of them keeps the plan's guarantees, judged here by the Python engine:
each state well formed and valid and, for a plan that keeps proxies serving, losing no request
(`lossless.request_problems`); each move's preconditions met and its effect the state the
subset names (the steps commute). Alloy judges the same states and moves
(`alloy_verify.alloy_batches`). A batch of k steps has 2^k states and k·2^(k-1) moves: a batch
has at most BATCH_MAX steps, and a plan past BATCH_BUDGET states × components is not batched."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator, Optional, Sequence

from checker.planning.durations import degraded_seconds
from checker.planning.lossless import request_problems
from checker.planning.plan import FULL_CHECK_LIMIT, Plan
from checker.semantic_model.actions import Action, effect, preconditions, state_refusals
from checker.semantic_model.config import Configuration

__all__ = ["BATCH_MAX", "BATCH_BUDGET", "Lattice", "batch_plan", "batch_refusal", "moves", "parallel_note"]

BATCH_MAX = 4
BATCH_BUDGET = FULL_CHECK_LIMIT


def moves(k: int) -> Iterator[tuple[int, int]]:
    """Every move of a batch of `k` steps: (subset done, as a bit mask; the step done next)."""
    for mask in range(1 << k):
        for j in range(k):
            if not mask & (1 << j):
                yield mask, j


@dataclass
class Lattice:
    """The states of a batch: the state before it with each subset of its steps done (a bit
    mask per subset), built one step at a time; `why` says what was refused ("" when nothing)."""

    plan: Plan
    start: Configuration
    steps: list[Action]
    states: dict[int, Configuration]
    why: str = ""

    @staticmethod
    def of(plan: Plan, start: Configuration) -> "Lattice":
        return Lattice(plan, start, [], {0: start})

    def add(self, a: Action) -> bool:
        """Add step `a` to the batch: True when every new state and move is allowed (else the
        lattice is unchanged and `why` says what fails)."""
        if any(s.component == a.component for s in self.steps):
            self.why = f"{a.component} is acted on twice"
            return False
        j, grown = len(self.steps), dict(self.states)
        bit = 1 << j
        for mask in sorted(self.states):      # into each new state by `a`, from the one without it
            why = _move(self.plan, self.states[mask], a, None)
            if why:
                self.why = why
                return False
            grown[mask | bit] = effect(self.plan.system, self.states[mask], a)
        for mask in sorted(self.states):      # and by each other step, from the new states without it
            for i, s in enumerate(self.steps):
                if mask & (1 << i):
                    why = _move(self.plan, grown[(mask & ~(1 << i)) | bit], s, grown[mask | bit])
                    if why:
                        self.why = why
                        return False
        why = _states(self.plan, [grown[m | bit] for m in sorted(self.states)])
        if why:
            self.why = why
            return False
        self.steps.append(a)
        self.states = grown
        return True


def _move(plan: Plan, before: Configuration, a: Action, after: Optional[Configuration]) -> str:
    """Why the move by `a` from `before` (to `after`, when given) is refused, or ""."""
    refused = preconditions(plan.system, before, a)
    if refused:
        return f"{a.describe()} is refused in some order: {refused[0]}"
    if after is not None and not _same(effect(plan.system, before, a), after):
        return f"{a.describe()} does not commute with the other steps"
    return ""


def _same(a: Configuration, b: Configuration) -> bool:
    return a.components == b.components and a.roles == b.roles and \
        {d for d in a.degraded if d[0] in a.components} == {d for d in b.degraded if d[0] in b.components}


def _states(plan: Plan, states: Sequence[Configuration]) -> str:
    """Why one of `states` is refused (not well formed, not valid, a request lost), or ""."""
    for s in states:
        refused = state_refusals(plan.system, s)
        if refused:
            return f"in some order, a state breaks {refused[0].rule}: {refused[0].text}"
    lost = request_problems(plan, states)
    return f"in some order, a client request could be lost: {lost[0].split(': ', 1)[1]}" if lost else ""


# the kinds of step that may be moved earlier, past steps of these kinds only, to run with a
# batch: re-linking and removing, never a mode change (which keeps the order the plan chose for
# the wire: a suspension before the request path is re-linked, the watchers resumed last) nor a
# create (a created component's degraded modes count from its create on)
MOVABLE = ("attach", "detach", "remove")
LOOKAHEAD = 12


def batch_plan(plan: Plan, first: int = 1, move: bool = True) -> tuple[list[Action], list[tuple[int, int]]]:
    """The steps of `plan` in the order they run and its batches (first and last step, from 1;
    at least two steps each), grown greedily from step `first`: a step joins the batch before it
    when every order of the two keeps the guarantees (`Lattice.add`); with `move`, a later
    re-linking step (MOVABLE, within LOOKAHEAD, past re-linking steps of other components) joins
    it when it does and the plan stays valid in its new order. No batch past BATCH_BUDGET."""
    steps = list(plan.steps)
    if (len(steps) + 1) * max(1, len(plan.states[0].components)) > BATCH_BUDGET:
        return steps, []
    states = list(plan.states)
    out: list[tuple[int, int]] = []
    i = first - 1
    while i < len(steps):
        lat = Lattice.of(plan, states[i])
        lat.add(steps[i])
        j = i + 1
        while j < len(steps) and len(lat.steps) < BATCH_MAX:
            cost = _Cost(plan, steps, out, i, j)
            if not (_joins(plan, lat, steps[j], cost.no_worse(steps))
                    or move and _moved(plan, steps, states, lat, j, cost)):
                break
            j += 1
        if j - i > 1:
            out.append((i + 1, j))
        i = j
    return steps, out


def _suspends(plan: Plan, a: Action) -> bool:
    """Whether `a` suspends or resumes a protocol the plan keeps requests flowing to."""
    return a.kind in ("degrade", "upgrade") and any(a.component == p for _, p in plan.protocols)


@dataclass
class _Cost:
    """The plan's degraded seconds weighted by criticality (checker.planning.durations) with the
    batches found so far and the one growing from step `i` (from 0): a step joins a batch only
    when that does not rise (a degrade run beside a create would start the wait early)."""

    plan: Plan
    steps: list[Action]
    out: list[tuple[int, int]]
    i: int
    j: int
    now: float = field(init=False)      # the steps as they are, the batch ending at step j

    def __post_init__(self) -> None:
        self.now = self.weighted(self.steps, self.j)

    def weighted(self, steps: Sequence[Action], j: int) -> float:
        batches = self.out + ([(self.i + 1, j)] if j - self.i > 1 else [])
        return degraded_seconds(self.plan.system, self.plan.states[0], steps, self.plan.durations(), batches).weighted

    def no_worse(self, steps: Sequence[Action]) -> bool:
        """Whether `steps` with the batch grown to step j + 1 (from 0: j) is no worse than the
        steps as they are with the batch ending at step j."""
        return self.weighted(steps, self.j + 1) <= self.now + 1e-9


def _serving(plan: Plan) -> bool:
    """Whether the plan keeps a service serving its clients throughout (an FTM transition)."""
    return bool(plan.serving or plan.handover)


def _joins(plan: Plan, lat: Lattice, a: Action, no_worse: bool) -> bool:
    """Whether `a` joins the batch `lat` (and does, when it can): not when that makes the plan's
    degraded seconds rise (`no_worse` false), nor a second create where a service is kept
    serving (process starts at once take the CPU the service needs: its replies came late).
    A protocol's suspension or resumption runs with
    mode changes only: the model allows a new node's input attached while a protocol is being
    suspended, but on the wire that node would hear the replies to requests the old path
    carries (docs/soundness.md#batches)."""
    if not no_worse or a.kind == "create" and _serving(plan) and any(s.kind == "create" for s in lat.steps):
        return False
    modes = all(s.kind in ("degrade", "upgrade") for s in lat.steps + [a])
    if not modes and (_suspends(plan, a) or any(_suspends(plan, s) for s in lat.steps)):
        return False
    return lat.add(a)


def _moved(plan: Plan, steps: list[Action], states: list[Configuration], lat: Lattice, j: int, cost: _Cost) -> bool:
    """Move a later step to position `j`, into the batch `lat`, when one can (see `batch_plan`);
    `steps` and `states` then hold the new order."""
    if steps[j].kind not in MOVABLE:
        return False
    passed = {steps[j].component}
    for k in range(j + 1, min(len(steps), j + 1 + LOOKAHEAD)):
        a = steps[k]
        if a.kind not in MOVABLE:
            return False
        if a.component not in passed:
            order = [a] + steps[j:k]
            run = _run(plan, states[j], order, states[k + 1])
            if run is not None and _joins(plan, lat, a, cost.no_worse(steps[:j] + order + steps[k + 1:])):
                steps[j:k + 1] = order
                states[j + 1:k + 1] = run
                return True
        passed.add(a.component)
    return False


def _run(plan: Plan, start: Configuration, order: list[Action], end: Configuration) -> Optional[list[Configuration]]:
    """The states after each but the last of `order` from `start`, when each step's preconditions
    hold, each state is allowed (`_states`) and the last is `end`; else None."""
    out, state = [], start
    for a in order:
        if preconditions(plan.system, state, a):
            return None
        state = effect(plan.system, state, a)
        out.append(state)
    if _states(plan, out[:-1]) or not _same(out[-1], end):
        return None
    return out[:-1]


def batch_refusal(plan: Plan, first: int, last: int) -> str:
    """Why steps `first`..`last` (from 1) of `plan` may not run together, or "" when they may."""
    if not 1 <= first < last <= len(plan.steps):
        return f"steps {first}–{last} are not a run of at least two steps of the plan's {len(plan.steps)}"
    if last - first + 1 > BATCH_MAX:
        return f"steps {first}–{last} are more than {BATCH_MAX} steps"
    lat = Lattice.of(plan, plan.states[first - 1])
    for a in plan.steps[first - 1:last]:
        if not lat.add(a):
            return lat.why
    return ""


def parallel_note(batches: Sequence[tuple[int, int]]) -> str:
    """The plan's note on its batches ("" when it has none)."""
    if not batches:
        return ""
    shown = ", ".join(f"{a}–{b}" for a, b in batches)
    return (f"steps {shown} run together, in batches: every order in which a batch's steps can complete keeps "
            "every state valid (docs/soundness.md#batches)")
