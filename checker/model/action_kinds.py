"""What makes a reconfiguration action a kind of its own, in one place per action.

An `ActionKind` ties an action class (`checker.model.actions`: its fields, its name `kind` and its
`symbol` as plans print them) to its preconditions, its effect, how it is recognised in the
difference between two configurations (`Change`), and how an Alloy module names its
arguments. `checker.model.actions.KINDS` is the registry of the six; the Python engine, the
Alloy modules (codegen.alloy) and the Alloy planner all read the actions through it.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Callable, Generic, Iterable, Protocol, TypeVar

from checker.model.config import Configuration, FuncId, Role

if TYPE_CHECKING:
    from checker.model.actions import Action, ActionBase, Snapshot, _Catalogue
    from checker.model.rules import Refusal

__all__ = ["ActionKind", "Change", "Kind", "Meaning"]

# An Alloy atom by what it stands for, as codegen.alloy's name map says it:
# ("component", c), ("connector", k), ("port", c, p), ("functionality", c, f).
Meaning = tuple[str, ...]


@dataclass(frozen=True)
class Change:
    """The difference between two configurations, element by element.

    A created or removed component's functionalities change mode with it (whichever way
    the configurations record the modes of absent components): only the modes of
    components present in both count as changes of their own."""

    removed: frozenset[str]
    created: frozenset[str]
    detached: frozenset[Role]
    attached: frozenset[Role]
    degraded: frozenset[FuncId]
    upgraded: frozenset[FuncId]

    @staticmethod
    def between(before: Configuration, after: Configuration) -> "Change":
        both = before.components & after.components
        return Change(
            removed=before.components - after.components,
            created=after.components - before.components,
            detached=before.roles - after.roles,
            attached=after.roles - before.roles,
            degraded=frozenset(f for f in after.degraded - before.degraded if f[0] in both),
            upgraded=frozenset(f for f in before.degraded - after.degraded if f[0] in both),
        )


A = TypeVar("A", bound="ActionBase")


class Kind(Protocol):
    """An action kind, whatever its class: what the registry holds."""

    @property
    def name(self) -> str: ...

    @property
    def symbol(self) -> str: ...

    @property
    def fields(self) -> tuple[str, ...]: ...

    @property
    def params(self) -> tuple[str, ...]: ...

    def owns(self, action: "Action") -> bool: ...

    def make(self, values: dict[str, str]) -> "ActionBase": ...

    def preconditions(self, st: "Snapshot", action: "Action") -> list["Refusal"]: ...

    def after(self, cat: "_Catalogue", config: Configuration, action: "Action") -> Configuration: ...

    def found(self, change: Change) -> list["Action"]: ...

    def recognise(self, before: Configuration, after: Configuration) -> list["Action"]: ...

    def alloy_args(self, action: "Action") -> tuple[Meaning, ...]: ...


@dataclass(frozen=True)
class ActionKind(Generic[A]):
    """One action: its class (fields, `kind`, `symbol`, `describe`), `precondition` (the
    failing preconditions, each with its rule's name (`checker.model.rules`), [] when it may
    run; the action's names are declared), `effect` (the configuration after
    it, preconditions not checked), `recognise` (the actions of this kind a `Change` is made
    of) and `args` (its arguments as the Alloy atoms' meanings, in the order of the Alloy
    predicate's parameters after the two configurations), whose kinds are `params`."""

    cls: type[A]
    precondition: Callable[["Snapshot", A], list["Refusal"]]
    effect: Callable[["_Catalogue", Configuration, A], Configuration]
    recognised: Callable[[Change], Iterable["Action"]]
    args: Callable[[A], tuple[Meaning, ...]]
    params: tuple[str, ...]

    @property
    def name(self) -> str:
        return self.cls.kind

    @property
    def symbol(self) -> str:
        return self.cls.symbol

    @property
    def fields(self) -> tuple[str, ...]:
        return tuple(f.name for f in fields(self.cls))

    def owns(self, action: "Action") -> bool:
        return isinstance(action, self.cls)

    def make(self, values: dict[str, str]) -> A:
        """The action of these field values (its dictionary form, the name left out)."""
        return self.cls(**values)

    def _own(self, action: "Action") -> A:
        if not isinstance(action, self.cls):
            raise TypeError(f"{action!r} is not a {self.name} action")
        return action

    def preconditions(self, st: "Snapshot", action: "Action") -> list["Refusal"]:
        return self.precondition(st, self._own(action))

    def after(self, cat: "_Catalogue", config: Configuration, action: "Action") -> Configuration:
        return self.effect(cat, config, self._own(action))

    def found(self, change: Change) -> list["Action"]:
        return list(self.recognised(change))

    def recognise(self, before: Configuration, after: Configuration) -> list["Action"]:
        """The actions of this kind the difference from `before` to `after` is made of."""
        return self.found(Change.between(before, after))

    def alloy_args(self, action: "Action") -> tuple[Meaning, ...]:
        return self.args(self._own(action))
