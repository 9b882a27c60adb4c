"""What makes a reconfiguration action a kind of its own, in one place per action.

An `ActionKind` ties an action class (`checker.semantic_model.actions`: its fields, its name `kind` and its
`symbol` as plans print them) to its preconditions, its effect, how it is recognised in the
difference between two configurations (`Change`), and how an Alloy module names its
arguments. `checker.semantic_model.actions.KINDS` is the registry of the six; the Python engine, the
Alloy modules (codegen.alloy) and the Alloy planner all read the actions through it.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Callable, Generic, Protocol, TypeVar, cast

from checker.semantic_model.config import Configuration, FuncId, Role

if TYPE_CHECKING:
    from checker.semantic_model.actions import Action, ActionBase, Snapshot, _Catalogue
    from checker.semantic_model.rules import Refusal

__all__ = ["ActionKind", "Change", "Kind", "Meaning"]

# An Alloy atom by what it stands for, as codegen.alloy's name map says it:
# ("component", c), ("connector", k), ("port", c, p), ("functionality", c, f).
Meaning = tuple[str, ...]
# The fields of an action that name each kind of its Alloy arguments (a port or a
# functionality is its component's).
ARGUMENT_FIELDS: dict[str, tuple[str, ...]] = {
    "component": ("component",), "connector": ("connector",),
    "port": ("component", "port"), "functionality": ("component", "functionality"),
}


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

    @property
    def seconds(self) -> float: ...

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
    failing preconditions, each with its rule's name (`checker.semantic_model.rules`), [] when it may
    run; the action's names are declared), `effect` (the configuration after it,
    preconditions not checked), `change_field` (the field of a `Change` whose elements are the
    actions of this kind a change is made of) and `params` (the kinds of its Alloy arguments,
    in the order of the Alloy predicate's parameters after the two configurations; each
    argument's meaning is read off the action's fields by `ARGUMENT_FIELDS`), and `seconds`
    (how long it takes on the wire by default: the median of the executor's step reports over
    `bench_live`'s scenarios, docs/soundness.md#seconds-on-the-wire)."""

    cls: type[A]
    precondition: Callable[["Snapshot", A], list["Refusal"]]
    effect: Callable[["_Catalogue", Configuration, A], Configuration]
    change_field: str
    params: tuple[str, ...]
    seconds: float

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
        make = cast("Callable[..., Action]", self.cls)     # every kind's class is one of the Action union
        return [make(*x) if isinstance(x, tuple) else make(x) for x in getattr(change, self.change_field)]

    def recognise(self, before: Configuration, after: Configuration) -> list["Action"]:
        """The actions of this kind the difference from `before` to `after` is made of."""
        return self.found(Change.between(before, after))

    def alloy_args(self, action: "Action") -> tuple[Meaning, ...]:
        own = self._own(action)
        return tuple((p, *(getattr(own, f) for f in ARGUMENT_FIELDS[p])) for p in self.params)
