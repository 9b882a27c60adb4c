"""The states s0…sn of a plan, held as its steps and every K-th state, not n full copies.

A plan of n steps on a system of m components has n + 1 states of up to m components each:
held in full that is n·m, which for a plan of 18,000 steps on 10,000 components is gigabytes.
`States` keeps the first and last state, one state in every `EVERY`, and the steps; any other
state is replayed from the checkpoint before it (at most EVERY - 1 effects), and the one read
last is kept, so reading the states in order costs one effect each. It is a read-only
`Sequence`: indexing, negative indices, slices (lazy windows on the same states), iteration,
`len` and equality with any sequence of configurations work as on a list.
"""
from __future__ import annotations

from typing import Iterator, Optional, Sequence, Union, overload

from checker.semantic_model.actions import Action, effect
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System

__all__ = ["States", "EVERY"]

EVERY = 64
"""One state in EVERY is kept in full (and the first and the last)."""


class States(Sequence[Configuration]):
    """The states of `steps` run from `start` (preconditions not checked: see `plan.verify`)."""

    def __init__(self, system: System, start: Configuration, steps: Sequence[Action],
                 checkpoints: Optional[dict[int, Configuration]] = None) -> None:
        self.system, self.steps = system, list(steps)
        self._kept: dict[int, Configuration] = {0: start}
        if checkpoints is not None:
            self._kept.update((i, s) for i, s in checkpoints.items() if self.keep(i, len(self.steps)))
        self._last: tuple[int, Configuration] = (0, start)
        if len(self.steps) not in self._kept:          # replay once: every checkpoint and the last state
            state = start
            for i, a in enumerate(self.steps, 1):
                state = effect(system, state, a)
                if self.keep(i, len(self.steps)):
                    self._kept[i] = state

    @staticmethod
    def keep(i: int, n: int) -> bool:
        """Whether state i of n + 1 is one a `States` keeps (for callers computing them anyway)."""
        return i % EVERY == 0 or i == n

    def __len__(self) -> int:
        return len(self.steps) + 1

    @overload
    def __getitem__(self, index: int) -> Configuration: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[Configuration]: ...

    def __getitem__(self, index: Union[int, slice]) -> Union[Configuration, Sequence[Configuration]]:
        if isinstance(index, slice):
            return _Window(self, range(len(self))[index])
        n = len(self)
        i = index + n if index < 0 else index
        if not 0 <= i < n:
            raise IndexError(f"state {index} of a plan with {n} states")
        hit = self._kept.get(i)
        if hit is not None:
            return hit
        j, state = self._last
        if not j <= i or i - j >= EVERY:
            j = i - i % EVERY
            state = self._kept[j]
        for a in self.steps[j:i]:
            state = effect(self.system, state, a)
        self._last = (i, state)
        return state

    def __iter__(self) -> Iterator[Configuration]:
        return self.run(0, len(self))

    def run(self, first: int, stop: int) -> Iterator[Configuration]:
        """States first … stop - 1 in order, one effect each after the first."""
        if first >= stop:
            return
        state = self[first]
        yield state
        for a in self.steps[first:stop - 1]:
            state = effect(self.system, state, a)
            yield state

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sequence) or isinstance(other, str):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"<States: {len(self)} states of a plan, {len(self._kept)} kept>"


class _Window(Sequence[Configuration]):
    """States `indices` of a `States`, read through it."""

    def __init__(self, states: States, indices: range) -> None:
        self.states, self.indices = states, indices

    def __len__(self) -> int:
        return len(self.indices)

    @overload
    def __getitem__(self, index: int) -> Configuration: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[Configuration]: ...

    def __getitem__(self, index: Union[int, slice]) -> Union[Configuration, Sequence[Configuration]]:
        if isinstance(index, slice):
            return _Window(self.states, self.indices[index])
        return self.states[self.indices[index]]

    def __iter__(self) -> Iterator[Configuration]:
        if self.indices.step == 1:
            yield from self.states.run(self.indices.start, self.indices.stop)
        else:
            for i in self.indices:
                yield self.states[i]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sequence) or isinstance(other, str):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other))

    __hash__ = None  # type: ignore[assignment]
