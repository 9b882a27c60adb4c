"""One list of rules, both engines (checker.semantic_model.rules, docs/soundness.md "One list of rules").

The table's names are exactly the labels of the Alloy templates' clauses; on one architecture
(tests/good_inputs/rules.arch) each rule has a witness, a configuration or a step that breaks
it and nothing else, which the Python engine refuses by that rule's name and Alloy's plan
evaluation refuses too; and the differential test (the two engines' verdicts on every
witness) fails when any rule is planted out of either engine.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, replace
from typing import Callable, Optional

import pytest

from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Upgrade,
    effect,
    state_refusals,
    step_refusals,
)
from checker.semantic_model.config import Configuration
from checker.semantic_model.rules import BY_NAME, RULES
from codegen.alloy import TEMPLATES
from reconf_dsl import ir
from reconf_dsl.loader import load
from tests.examples_table import path

LABEL = re.compile(r"--@(?:pre|post|rule) (\S+)")


def labels() -> dict[str, int]:
    """Each label of the shared templates, with the number of lines it tags."""
    found: dict[str, int] = {}
    for name in ("semantics.j2", "actions.j2"):
        for rule in LABEL.findall((TEMPLATES / name).read_text(encoding="utf-8")):
            found[rule] = found.get(rule, 0) + 1
    return found


def test_the_table_is_the_templates_labels() -> None:
    """A rule added to the table without its Alloy clause, or a labelled clause without its
    row, fails here; one the Python engine does not refuse by fails the witnesses below."""
    assert sorted(labels()) == sorted(BY_NAME)
    assert len(BY_NAME) == len(RULES)
    for rule in RULES:
        assert rule.side in ("", "python", "alloy", "both") and bool(rule.side) == bool(rule.witness), rule.name


@dataclass(frozen=True)
class Witness:
    """A configuration (`action` None) or a step that breaks `rule` alone."""

    rule: str
    before: Configuration
    action: Optional[Action] = None
    after: Optional[Configuration] = None


def _system() -> ir.System:
    return load([path("tests", "good_inputs", "rules.arch")])


def _rule_iii_broken(system: ir.System) -> ir.System:
    """The DSL refuses it (RC112): spare's degraded guarantee promises more than its normal one."""
    spare = system.component("spare")
    assert spare is not None
    (idle,) = spare.functionalities
    assert idle.normal is not None and idle.degraded is not None
    odd = replace(idle, normal=replace(idle.normal, guarantees=(ir.Guarantee("out", ir.Predicate(None)),)),
                  degraded=replace(idle.degraded, guarantees=(ir.Guarantee("out", ir.Predicate("String")),)))
    comps = tuple(replace(c, functionalities=(odd,)) if c.name == "spare" else c for c in system.components)
    return replace(system, components=comps)


def witnesses(system: ir.System) -> list[Witness]:
    start = Configuration.initial(system)

    def with_(roles: tuple[tuple[str, str, str], ...] = (), comps: tuple[str, ...] = (),
              degraded: tuple[tuple[str, str], ...] = (), without: tuple[tuple[str, str, str], ...] = ()
              ) -> Configuration:
        return Configuration(start.components | set(comps), start.degraded | set(degraded),
                             (start.roles | set(roles)) - set(without))

    chatter_in, spare_idle = ("/chatter", "listener", "in"), ("spare", "idle")
    v2 = with_(comps=("talker_v2",))
    return [
        Witness("state.valid", with_(without=(chatter_in,))),
        Witness("state.single", with_(roles=(("/chatter", "talker_v2", "out"),), comps=("talker_v2",))),
        Witness("state.service", with_(roles=(("/ask", "backup", "reply"),))),
        Witness("state.typed", with_(roles=(("/count", "listener", "in"),))),
        Witness("state.owned", with_(roles=(("/plain", "talker_v2", "out"),))),
        Witness("remove.present", start, Remove("talker_v2")),
        Witness("remove.isolated", start, Remove("talker")),
        Witness("remove.effect", start, Remove("spare"), start),
        Witness("create.absent", with_(degraded=(spare_idle,)), Create("spare")),
        Witness("create.effect", start, Create("talker_v2"), start),
        Witness("detach.attached", start, Detach("/plain", "spare", "out")),
        Witness("detach.present", with_(roles=(("/plain", "talker_v2", "out"),)), Detach("/plain", "talker_v2", "out")),
        Witness("detach.input", start, Detach(*chatter_in)),
        Witness("detach.output", start, Detach("/chatter", "talker", "out")),
        Witness("detach.effect", start, Detach("/count", "counter", "out"), start),
        Witness("attach.present", start, Attach("/chatter", "listener_v2", "in")),
        Witness("attach.detached", start, Attach(*chatter_in)),
        Witness("attach.output", with_(degraded=(spare_idle,)), Attach("/plain", "spare", "out")),
        Witness("attach.input", start, Attach("/count", "listener", "in")),
        Witness("attach.single", v2, Attach("/chatter", "talker_v2", "out")),
        Witness("attach.service", start, Attach("/ask", "backup", "reply")),
        Witness("attach.effect", start, Attach("/plain", "spare", "out"), start),
        Witness("degrade.present", start, Degrade("talker_v2", "talk")),
        Witness("degrade.normal", with_(degraded=(spare_idle,)), Degrade(*spare_idle)),
        Witness("degrade.safe", start, Degrade("talker", "talk")),
        Witness("degrade.effect", start, Degrade(*spare_idle), start),
        Witness("upgrade.present", start, Upgrade("talker_v2", "talk")),
        Witness("upgrade.degraded", start, Upgrade(*spare_idle)),
        Witness("upgrade.assumptions", with_(without=(chatter_in,), degraded=(("listener", "listen"),)),
                Upgrade("listener", "listen")),
        Witness("upgrade.effect", with_(degraded=(spare_idle,)), Upgrade(*spare_idle), with_(degraded=(spare_idle,))),
    ]


def _odd_witness(system: ir.System) -> Witness:
    """upgrade.connectors: only an architecture that breaks rule iii on modes shows it."""
    start = Configuration.initial(system)
    pre = Configuration(start.components, start.degraded | {("spare", "idle")}, start.roles | {("/plain", "spare", "out")})
    return Witness("upgrade.connectors", pre, Upgrade("spare", "idle"))


def all_witnesses() -> list[tuple[ir.System, Witness]]:
    system = _system()
    odd = _rule_iii_broken(system)
    return [(system, w) for w in witnesses(system)] + [(odd, _odd_witness(odd))]


def python_refuses(system: ir.System, w: Witness, planted: str = "") -> set[str]:
    """The rules the Python engine refuses the witness by (`planted` left out)."""
    if w.action is None:
        found = state_refusals(system, w.before)
    else:
        after = w.after if w.after is not None else effect(system, w.before, w.action)
        found = step_refusals(system, w.before, w.action, after)
    return {r.rule for r in found} - {planted}


def alloy_refuses(cases: list[tuple[ir.System, Witness]]) -> list[bool]:
    """Whether Alloy's plan evaluation refuses each witness, in one instance per system: its
    configurations (valid and well formed) or its step (the action's predicate)."""
    from checker.alloy.instance import alloy_plan_verdict

    out: dict[int, bool] = {}
    by_system: dict[int, list[int]] = {}
    for i, (system, _) in enumerate(cases):
        by_system.setdefault(id(system), []).append(i)
    for indices in by_system.values():
        system = cases[indices[0]][0]
        configs: list[Configuration] = []
        actions: list[Optional[Action]] = []
        where: list[tuple[int, int]] = []      # per witness: its state, or its step
        for i in indices:
            w = cases[i][1]
            if configs:
                actions.append(None)
            if w.action is None:
                where.append((len(configs), -1))
                configs.append(w.before)
                continue
            after = w.after if w.after is not None else effect(system, w.before, w.action)
            where.append((-1, len(configs)))
            configs += [w.before, after]
            actions.append(w.action)
        verdict = alloy_plan_verdict(system, configs, actions=actions)
        for i, (state, step) in zip(indices, where):
            out[i] = (not (verdict.valid[state] and verdict.formed[state]) if step < 0
                      else cases[i][1].action.kind not in verdict.steps[step])  # type: ignore[union-attr]
    return [out[i] for i in range(len(cases))]


def differential(cases: list[tuple[ir.System, Witness]], planted: str = "") -> list[str]:
    """The witnesses the two engines judge differently (`planted` left out of Python's rules)."""
    alloy = alloy_refuses(cases)
    return [w.rule for (system, w), refused in zip(cases, alloy) if bool(python_refuses(system, w, planted)) != refused]


def test_every_rule_has_a_witness_or_says_why() -> None:
    shown = {w.rule for _, w in all_witnesses()}
    for rule in RULES:
        assert (rule.name in shown) == (rule.side != "both"), rule.name


def test_the_python_engine_refuses_each_witness_by_its_rule_alone() -> None:
    for system, w in all_witnesses():
        assert python_refuses(system, w) == {w.rule}, w.rule


@pytest.mark.alloy
def test_both_engines_refuse_every_witness() -> None:
    cases = all_witnesses()
    assert all(alloy_refuses(cases))
    assert differential(cases) == []


@pytest.mark.alloy
def test_a_rule_planted_out_of_the_python_engine_is_caught() -> None:
    cases = all_witnesses()
    for rule in RULES:
        if rule.side in ("python", "both"):
            continue
        assert rule.name in differential(cases, planted=rule.name), rule.name


def _without(rule: str) -> Callable[[str], str]:
    pattern = re.compile(rf"^.*--@(?:pre|post|rule) {re.escape(rule)}\s*$\n", re.MULTILINE)

    def cut(source: str) -> str:
        return pattern.sub("", source)
    return cut


@pytest.mark.alloy
@pytest.mark.parametrize("rule", [r.name for r in RULES if r.side not in ("alloy", "both")])
def test_a_rule_planted_out_of_alloy_is_caught(monkeypatch: pytest.MonkeyPatch, rule: str) -> None:
    import jinja2

    import codegen.alloy
    from checker.alloy.evaluate import forget

    real = codegen.alloy.environment()
    cut = _without(rule)
    planted = {name: cut(real.loader.get_source(real, name)[0])  # type: ignore[union-attr]
               for name in ("semantics.j2", "actions.j2")}
    env = real.overlay(loader=jinja2.ChoiceLoader([jinja2.DictLoader(planted), real.loader]))
    monkeypatch.setattr(codegen.alloy, "environment", lambda: env)
    forget()
    try:
        cases = [(s, w) for s, w in all_witnesses() if w.rule == rule]
        assert differential(cases) == [rule]
    finally:
        monkeypatch.undo()
        forget()
