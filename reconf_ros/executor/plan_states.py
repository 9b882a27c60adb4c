"""Configurations (`State`) and the states of a plan (`PlanStates`), read from a plan document."""
from __future__ import annotations

from typing import Any, Collection, Iterable, Iterator, Optional, Sequence

Degraded = tuple[str, str]           # (component, functionality)
Role = tuple[str, str, str]          # (connector, component, port)


class State:
    """A configuration: present components, degraded (component, functionality), roles
    (connector, component, port)."""

    def __init__(self, components: Iterable[str], degraded: Iterable[Any], roles: Iterable[Any]) -> None:
        # frozensets are taken as they are (a state derived from another shares its unchanged parts)
        self.components: frozenset[str] = components if isinstance(components, frozenset) else frozenset(components)
        self.degraded: frozenset[Degraded] = degraded if isinstance(degraded, frozenset) \
            else frozenset((d[0], d[1]) for d in degraded)
        self.roles: frozenset[Role] = roles if isinstance(roles, frozenset) \
            else frozenset((r[0], r[1], r[2]) for r in roles)

    @staticmethod
    def from_doc(d: dict[str, Any]) -> "State":
        return State(d["components"], d["degraded"], d["roles"])

    def changed(self, change: dict[str, Any]) -> "State":
        """This state with a plan document's change of one step applied (format 2: `add`, `drop`)."""
        parts: list[frozenset[Any]] = []
        for key, now in zip(("components", "degraded", "roles"), self.key()):
            add, drop = ({x if isinstance(x, str) else tuple(x) for x in change.get(side, {}).get(key, ())}
                         for side in ("add", "drop"))
            parts.append((now - drop) | add if add or drop else now)
        return State(parts[0], parts[1], parts[2])

    def to_doc(self) -> dict[str, Any]:
        return {"components": sorted(self.components), "degraded": [list(d) for d in sorted(self.degraded)],
                "roles": [list(r) for r in sorted(self.roles)]}

    def key(self) -> tuple[frozenset[str], frozenset[Degraded], frozenset[Role]]:
        return (self.components, self.degraded, self.roles)

    def only(self, comps: Iterable[str]) -> "State":
        keep = set(comps)
        return State(self.components & keep, [d for d in self.degraded if d[0] in keep],
                     [r for r in self.roles if r[1] in keep])

    def describe(self) -> str:
        comps = ", ".join(sorted(self.components)) or "-"
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(self.degraded) if c in self.components) or "-"
        roles = ", ".join(f"{c}.{p}@{n}" for n, c, p in sorted(self.roles)) or "-"
        return f"components: {comps}\n    degraded: {degraded}\n    attachments: {roles}"


class PlanStates:
    """The states of a plan document's plan: from its first state and each step's change
    (format 2), one state in 64 kept and the others replayed, so a plan of n steps on m
    components does not take n·m in memory; or every state as recorded (format 1)."""

    EVERY = 64

    def __init__(self, plan: dict[str, Any]) -> None:
        self.changes: list[dict[str, Any]] = plan.get("changes", [])
        self.kept: dict[int, State] = {}
        if "states" in plan:
            self.kept = {i: State.from_doc(st) for i, st in enumerate(plan["states"])}
            self.n = len(self.kept)
        elif "start" in plan:
            state = State.from_doc(plan["start"])
            self.kept[0], self.n = state, len(self.changes) + 1
            for i, change in enumerate(self.changes, 1):
                state = state.changed(change)
                if i % self.EVERY == 0 or i == len(self.changes):
                    self.kept[i] = state
        else:
            self.n = 0
        self.last: tuple[int, Optional[State]] = (0, self.kept.get(0))

    def __len__(self) -> int:
        return self.n

    def __bool__(self) -> bool:
        return self.n > 0

    def __getitem__(self, index: int) -> State:
        i = index + self.n if index < 0 else index
        if not 0 <= i < self.n:
            raise IndexError(f"state {index} of a plan with {self.n} states")
        if i in self.kept:
            return self.kept[i]
        j, state = self.last
        if state is None or not j <= i or i - j >= self.EVERY:
            j = i - i % self.EVERY
            state = self.kept[j]
        for change in self.changes[j:i]:
            state = state.changed(change)
        self.last = (i, state)
        return state

    def alone(self, before: State, i: int) -> State:
        """`before` with step `i`'s change alone applied (format 2), or the state after step `i`
        (format 1, which has no batches)."""
        return before.changed(self.changes[i - 1]) if self.changes else self[i]

    def __iter__(self) -> Iterator[State]:
        if not self.n:
            return
        state = self.kept[0]
        yield state
        for i in range(1, self.n):
            state = self.kept.get(i) or state.changed(self.changes[i - 1])
            yield state


Timed = tuple[int, float, float, bool]      # a step as a run timed it: (step, began, ended, ok)


def degraded_spans(states: PlanStates, timed: Sequence[Timed], removes: Collection[int],
                   end: float) -> dict[str, list[tuple[float, float]]]:
    """Each functionality's degraded spans in a run ("comp.func" -> (began, ended) pairs), from
    the first timed step's start: a step takes effect at its own end, in the order the steps
    ended (the steps of a batch overlap, on distinct components: docs/executor.md#batches), but
    a component's remove (its step in `removes`) ends its spans at the remove's start (it serves
    no one while it goes, as the plan's estimate counts); a step that failed changed nothing of
    the plan's; a span still open ends at `end`. What `reconf timeline` draws and a run's last
    lines sum (docs/soundness.md#seconds-on-the-wire)."""
    if not timed:
        return {}
    first = min(timed)
    state = states[first[0] - 1]
    since = {f"{c}.{f}": first[1] for c, f in state.degraded}
    spans: dict[str, list[tuple[float, float]]] = {}
    for step, began, ended, ok in sorted(timed, key=lambda t: t[2]):
        if not ok:
            continue
        state = states.alone(state, step)
        now = {f"{c}.{f}" for c, f in state.degraded}
        for name in now - set(since):
            since[name] = ended
        stop = began if step in removes else ended
        for name in set(since) - now:
            start = since.pop(name)
            spans.setdefault(name, []).append((start, max(stop, start)))
    for name, start in since.items():
        spans.setdefault(name, []).append((start, max(end, start)))
    return spans
