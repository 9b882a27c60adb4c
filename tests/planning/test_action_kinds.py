"""The registry of actions (checker.semantic_model.actions.KINDS): each kind is defined once, and what the
Python engine does, the Alloy modules read and the Alloy planner decodes agree with it."""
from __future__ import annotations

from typing import get_args

import pytest

from checker.semantic_model.actions import (
    KINDS,
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Upgrade,
    action_from_dict,
    changes,
    effect,
    kind_of,
    recognise,
)
from checker.semantic_model.config import Configuration
from codegen.alloy import alloy_view, step_action
from reconf_dsl.ir import System
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES


def candidates(system: System, config: Configuration) -> list[Action]:
    """Every action that changes `config`: one of each kind per element it can act on."""
    comps = {c.name: c for c in list(system.components) + list(system.versions)}
    out: list[Action] = [Remove(c) for c in sorted(config.components)]
    out += [Create(c) for c in sorted(comps) if c not in config.components]
    out += [Detach(*r) for r in sorted(config.roles)]
    out += [Attach(k.name, c, p.name) for k in system.connectors for c in sorted(config.components)
            for p in comps[c].ports if (k.name, c, p.name) not in config.roles]
    funcs = [(c, f.name) for c in sorted(config.components) for f in comps[c].functionalities]
    out += [Degrade(*f) for f in funcs if f not in config.degraded]
    out += [Upgrade(*f) for f in funcs if f in config.degraded]
    return out


def configurations(system: System) -> list[Configuration]:
    """The initial configuration, one with an attachment gone and a functionality degraded,
    and one with a component gone as well."""
    start = Configuration.initial(system)
    later = start
    for kind in ("detach", "degrade"):
        for action in [a for a in candidates(system, start) if a.kind == kind][:1]:
            later = effect(system, later, action)
    return [start, later, effect(system, later, Remove(min(later.components)))]


def test_every_action_class_has_one_kind() -> None:
    classes = get_args(Action)
    assert [k.name for k in KINDS] == [c.kind for c in classes]
    assert len({k.symbol for k in KINDS}) == len({k.name for k in KINDS}) == len(KINDS) == len(classes)
    for cls in classes:
        (kind,) = [k for k in KINDS if k.name == cls.kind]
        assert kind.symbol == cls.symbol


@pytest.mark.parametrize("kind", KINDS, ids=[k.name for k in KINDS])
def test_every_kind_round_trips_through_its_dictionary(kind) -> None:  # type: ignore[no-untyped-def]
    action = action_from_dict({"action": kind.name, **{f: f"x{i}" for i, f in enumerate(kind.fields)}})
    assert kind_of(action) is kind and kind.owns(action)
    assert list(action.to_dict()) == ["action", *kind.fields]
    assert action_from_dict(action.to_dict()) == action
    assert action.describe().startswith(kind.name)


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.name for e in EXAMPLES])
def test_every_effect_is_recognised_as_its_action(example) -> None:  # type: ignore[no-untyped-def]
    """Between `before` and `effect(before)`, the action's kind recognises the action and
    no other kind recognises anything, in the Python engine's configurations and in the
    Alloy modules' view of them (absent components degraded), with the Alloy arguments."""
    system = load([example.file])
    for before in configurations(system):
        for action in candidates(system, before):
            after = effect(system, before, action)
            kind = kind_of(action)
            assert kind.recognise(before, after) == [action], action
            assert changes(before, after) == [action] and recognise(before, after) == action, action
            assert step_action(alloy_view(system, before), alloy_view(system, after)) == \
                (kind.name, kind.alloy_args(action)), action


def test_the_examples_exercise_every_kind() -> None:
    seen = {a.kind for e in EXAMPLES for system in [load([e.file])]
            for c in configurations(system) for a in candidates(system, c)}
    assert seen == {k.name for k in KINDS}


def test_two_changes_are_not_one_action() -> None:
    system = load([EXAMPLES[0].file])
    start = Configuration.initial(system)
    first, second = candidates(system, start)[:2]
    after = effect(system, effect(system, start, first), second)
    assert recognise(start, after) is None and step_action(start, after) is None
    assert sorted(a.describe() for a in changes(start, after)) == sorted([first.describe(), second.describe()])
    assert recognise(start, start) is None and changes(start, start) == []


def test_preconditions_and_effects_dispatch_through_the_registry() -> None:
    system = load([EXAMPLES[0].file])
    start = Configuration.initial(system)
    from checker.semantic_model.actions import Snapshot, catalogue, check
    st = Snapshot(catalogue(system), start)
    for action in candidates(system, start):
        assert check(st, action) == [r.text for r in kind_of(action).preconditions(st, action)]
        assert effect(system, start, action) == kind_of(action).after(catalogue(system), start, action)
    with pytest.raises(TypeError):
        KINDS[0].preconditions(st, Create("x"))
