"""The six actions: forms, preconditions in words, and safety (valid → valid)."""
from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from checker.semantic_model.actions import (
    Action,
    ActionRefused,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Upgrade,
    action_from_dict,
    apply,
    effect,
    is_valid,
    preconditions,
)
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from tests.support.random_systems import random_system
from tests.support.systems import talker_system

ALL: list[Action] = [Remove("c"), Create("c"), Detach("/t", "c", "p"), Attach("/t", "c", "p"), Degrade("c", "f"),
                     Upgrade("c", "f")]


def test_forms_round_trip_and_symbols_differ() -> None:
    for a in ALL:
        assert action_from_dict(a.to_dict()) == a
        assert a.describe().startswith(a.kind)
    assert len({a.symbol for a in ALL}) == 6


def test_preconditions_in_words() -> None:
    s = talker_system()
    c0 = Configuration.initial(s)
    assert preconditions(s, c0, Remove("talker")) == ["talker is not isolated: talker.out is attached to /chatter"]
    assert preconditions(s, c0, Create("talker")) == ["talker is already in the system"]
    [why] = preconditions(s, c0, Detach("/chatter", "talker", "out"))
    assert "no other output satisfies /chatter" in why and "listener.listen" in why and "safe_no_input" in why
    [why] = preconditions(s, c0, Detach("/chatter", "listener", "in"))
    assert "listener.listen is not safe without input listener.in" in why
    [why] = preconditions(s, c0, Degrade("talker", "talk"))
    assert why.startswith("degrading talker.talk leaves /chatter unsatisfied") and "listener.listen" in why
    assert preconditions(s, c0, Degrade("listener", "listen")) == []
    assert preconditions(s, c0, Upgrade("listener", "listen")) == ["listener.listen is not degraded"]
    assert preconditions(s, c0, Attach("/chatter", "talker_v2", "out")) == [
        "talker_v2.out is not a port of a present component (talker_v2 is not in the system)"]
    c1 = apply(s, c0, Create("talker_v2"))
    assert ("talker_v2", "talk") in c1.degraded
    [why] = preconditions(s, c1, Attach("/chatter", "talker_v2", "out"))
    assert "current guarantee of talker_v2.out (nothing) does not satisfy" in why
    c2 = apply(s, apply(s, c0, Degrade("listener", "listen")), Detach("/chatter", "talker", "out"))
    assert preconditions(s, c2, Upgrade("listener", "listen")) == [
        "the normal mode of listener.listen assumes String @ 10 Hz, which does not hold now"]
    with pytest.raises(ActionRefused):
        apply(s, c0, Remove("talker"))


def test_single_topic_refuses_a_second_publisher() -> None:
    s = talker_system(single=True)
    c = Configuration.initial(s)
    for a in (Create("talker_v2"), Upgrade("talker_v2", "talk")):
        c = apply(s, c, a)
    assert preconditions(s, c, Attach("/chatter", "talker_v2", "out")) == [
        "/chatter takes a single publisher and already has talker.out"]


def test_remove_drops_degraded_entries() -> None:
    s = talker_system()
    c = Configuration.initial(s)
    for a in (Create("talker_v2"), Remove("talker_v2")):
        c = apply(s, c, a)
    assert not c.degraded


def _candidates(s, config):  # type: ignore[no-untyped-def]
    names = sorted(c.name for c in s.components + s.versions)
    out = [Create(n) for n in names] + [Remove(n) for n in names]
    for comp in s.components + s.versions:
        out += [Degrade(comp.name, f.name) for f in comp.functionalities]
        out += [Upgrade(comp.name, f.name) for f in comp.functionalities]
        for p in comp.ports:
            for conn in s.connectors:
                out += [Attach(conn.name, comp.name, p.name), Detach(conn.name, comp.name, p.name)]
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), walk=st.integers(0, 2**32 - 1))
def test_every_applicable_action_keeps_a_valid_configuration_valid(seed: int, walk: int) -> None:
    s = random_system(seed, n=3)
    if s is None:
        return
    rng = random.Random(walk)
    config = Configuration.initial(s)
    assert evaluate(s, config).valid
    for _ in range(25):
        ok = [a for a in _candidates(s, config) if not preconditions(s, config, a)]
        if not ok:
            break
        config = effect(s, config, rng.choice(ok))
        ev = evaluate(s, config, explain=False)
        assert ev.valid, ev.unsatisfied
        assert is_valid(s, config)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), pick=st.integers(0, 2**32 - 1))
def test_fast_validity_agrees_with_the_engine(seed: int, pick: int) -> None:
    s = random_system(seed, n=3)
    if s is None:
        return
    rng = random.Random(pick)
    full = Configuration.initial(s)
    comps = frozenset(c for c in full.components if rng.random() < 0.8)
    funcs = [(c.name, f.name) for c in s.components for f in c.functionalities if c.name in comps]
    config = Configuration(comps, frozenset(f for f in funcs if rng.random() < 0.3),
                           frozenset(r for r in full.roles if r[1] in comps and rng.random() < 0.8))
    assert is_valid(s, config) == evaluate(s, config, explain=False).valid
