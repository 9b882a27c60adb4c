"""One semantics in both engines: on random reachable configurations, every candidate
action is allowed by the Python engine exactly when the Alloy plan module's action
predicate (the meta-model's, shared through the templates) holds. And the plans the
two readings used to disagree on are accepted by Alloy (docs/soundness.md, "One semantics")."""
from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from checker.alloy import AlloyBridge
from checker.alloy.evaluate import forget
from checker.alloy.instance import alloy_plan_verdict
from checker.planning import plan_migrate, plan_remove
from checker.planning.alloy_verify import alloy_evidence
from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Upgrade,
    effect,
    is_valid,
    preconditions,
)
from checker.semantic_model.config import Configuration
from reconf_dsl import ir
from reconf_dsl.loader import load
from tests.examples_table import path
from tests.support.semantic_strategies import dense

STRATEGIES = ("paper", "default", "exhaustive")


def candidates(system: ir.System, s: Configuration) -> list[Action]:
    """Every action whose arguments make sense in s (present, attached, in its mode): the
    safety preconditions are what the two engines are compared on."""
    out: list[Action] = []
    for c in system.components:
        if c.name not in s.components:
            out.append(Create(c.name))
            continue
        out.append(Remove(c.name))
        for f in c.functionalities:
            out.append(Upgrade(c.name, f.name) if (c.name, f.name) in s.degraded else Degrade(c.name, f.name))
        for k in system.connectors:
            for p in c.ports:
                if (k.name, c.name, p.name) not in s.roles:
                    out.append(Attach(k.name, c.name, p.name))
    out += [Detach(k, c, p) for k, c, p in sorted(s.roles)]
    return out


def walk(system: ir.System, s: Configuration, rng: random.Random, steps: int) -> list[Configuration]:
    """s and the configurations reached from it by actions the Python engine allows."""
    out = [s]
    for _ in range(steps):
        allowed = [a for a in candidates(system, s) if not preconditions(system, s, a)]
        # the start is wired up as far as it goes: taking it apart reaches what a plan does
        weights = [3 if isinstance(a, (Detach, Degrade, Remove)) else 1 for a in allowed]
        s = effect(system, s, rng.choices(allowed, weights)[0])
        assert is_valid(system, s)
        out.append(s)
    return out


def judged_alike(system: ir.System, states: list[Configuration]) -> None:
    """Every candidate action out of every state judged by both engines, alike. One plan
    module judges them all: s, a1(s), s, a2(s), ... ; the steps out of s are read."""
    configs: list[Configuration] = []
    judged: list[tuple[Configuration, Action]] = []
    for s in states:
        for a in candidates(system, s):
            configs += [s, effect(system, s, a)]
            judged.append((s, a))
    verdict = alloy_plan_verdict(system, configs + [states[0]])
    for i, (s, a) in enumerate(judged):
        python = not preconditions(system, s, a)
        alloy = a.kind in verdict.steps[2 * i]
        assert python == alloy, (a.describe(), preconditions(system, s, a), s)


@given(dense(), st.randoms(use_true_random=False))
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_engines_judge_every_action_alike(case: tuple[ir.System, Configuration], rng: random.Random) -> None:
    system, start = case
    judged_alike(system, walk(system, start, rng, 3))


def test_engines_judge_alike_where_the_readings_part() -> None:
    """The configurations where the paper's readings and these part, whatever the random
    walks above reach: a functionality on a self-loop, and an input on two connectors."""
    loop = load([path("tests", "good_inputs", "self_loop.arch")])
    judged_alike(loop, [Configuration.initial(loop)])
    old, new = _moves()
    plan = plan_migrate(old, new)
    judged_alike(plan.system, list(plan.states))


def test_the_readings_that_differ_from_the_papers() -> None:
    """Where the paper's reading and this one part: a functionality reading its own output
    may degrade (its degraded mode assumes nothing), and an input's only attachment may not
    go while it is needed."""
    loop = load([path("tests", "good_inputs", "self_loop.arch")])
    s = Configuration.initial(loop)
    assert preconditions(loop, s, Degrade("a", "f")) == []
    (why,) = preconditions(loop, s, Detach("/t", "a", "i"))
    assert why.startswith("a.f is not safe without input a.i")


def _moves() -> tuple[ir.System, ir.System]:
    return (load([path("tests", "good_inputs", "move_subscriber_a.arch")]),
            load([path("tests", "good_inputs", "move_subscriber_b.arch")]))


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_self_loop_removal_is_accepted(bridge: AlloyBridge, strategy: str) -> None:
    plan = plan_remove(load([path("tests", "good_inputs", "self_loop.arch")]), "a", strategy)
    evidence = alloy_evidence(plan)
    assert evidence["valid"], evidence.get("reason")
    assert [a.kind for a in plan.steps][0] == "degrade" and plan.steps[-1] == Remove("a")


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_subscriber_moved_between_topics_is_accepted(bridge: AlloyBridge, strategy: str) -> None:
    old, new = _moves()
    plan = plan_migrate(old, new, strategy)
    evidence = alloy_evidence(plan)
    assert evidence["valid"], evidence.get("reason")
    assert Detach("/a", "s", "i") in plan.steps and Attach("/b", "s", "i") in plan.steps
    if strategy != "paper":    # attach first, then detach: s.listen is never degraded
        assert plan.disruption == 0 and plan.steps == [Attach("/b", "s", "i"), Detach("/a", "s", "i")]


def test_the_alloy_planner_reads_them_alike(bridge: AlloyBridge) -> None:
    """The Alloy planner's actions are the same templates: it finds the same two plans."""
    from checker.planning import Problem
    from checker.planning.alloy_search import plan_with_alloy

    old, new = _moves()
    for p in (plan_remove(load([path("tests", "good_inputs", "self_loop.arch")]), "a"), plan_migrate(old, new)):
        planned = plan_with_alloy(Problem(p.system, p.states[0], p.goal, renames=dict(p.renames)), 8)
        # the same actions at the same disruption (two detaches may come in either order)
        assert (sorted(map(str, planned.steps)), planned.disruption) == (sorted(map(str, p.steps)), p.disruption)


# The paper's readings, planted back into the templates the plan modules are rendered from.
PAPER_READINGS = [
    ("detach: safe without the whole input", "k -> p]\n", "Connector -> p]\n", "detach s.i from /a"),
    ("degrade: f not exempt", ").funcs - f, aff -> Input]", ").funcs, aff -> Input]", "degrade a.f"),
]


@pytest.mark.parametrize("reading,right,planted,refused", PAPER_READINGS, ids=[r[0] for r in PAPER_READINGS])
def test_a_paper_reading_planted_back_is_caught(monkeypatch: pytest.MonkeyPatch, reading: str, right: str,
                                                planted: str, refused: str) -> None:
    import jinja2

    import codegen.alloy

    real = codegen.alloy.environment()
    source = real.loader.get_source(real, "actions.j2")[0]   # type: ignore[union-attr]
    assert source.count(right) == 2, right                   # the quantified and the join encoding
    loader = jinja2.ChoiceLoader([jinja2.DictLoader({"actions.j2": source.replace(right, planted)}), real.loader])
    env = real.overlay(loader=loader)
    monkeypatch.setattr(codegen.alloy, "environment", lambda: env)
    forget()     # the evaluation modules rendered from the planted templates
    try:
        # the Python engine allows the action, the planted reading refuses it
        with pytest.raises(AssertionError, match=f"'{refused}', \\[\\]"):
            test_engines_judge_alike_where_the_readings_part()
    finally:
        monkeypatch.undo()
        forget()
