"""Large modules parsed in two parts (checker.alloy.split) give the text's verdicts."""
from __future__ import annotations

import pytest

from bench.gen import generate, hub_component
from checker.alloy import AlloyBridge, alloy_plan_verdict, alloy_verdict
from checker.alloy import split as split_mod
from checker.alloy.errors import AlloyError
from checker.alloy.split import IDENTIFIER, split_module
from checker.planning import plan_replace
from checker.semantic_model.config import Configuration
from codegen.alloy import render_instance, render_plan
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES

CHATTER = next(e for e in EXAMPLES if e.name == "chatter").file


def _chatter_states() -> tuple[object, list[Configuration], list[Configuration]]:
    system = load([CHATTER])
    c0 = Configuration.initial(system)
    listener = frozenset(("listener", f.name) for c in system.components if c.name == "listener"
                         for f in c.functionalities)
    talker = frozenset(r for r in c0.roles if r[1] == "talker")
    c1 = Configuration(c0.components, c0.degraded | listener, c0.roles)
    c2 = Configuration(c1.components, c1.degraded, c1.roles - talker)
    early = Configuration(c0.components, c0.degraded, c2.roles)
    return system, [c0, c1, c2], [c0, early]


def test_the_skeleton_moves_every_atom_and_each_body_that_names_one() -> None:
    system, safe, _ = _chatter_states()
    text, names = render_plan(system, safe)
    assert split_module(text) is None  # small: parsed as it is
    split = split_module(text, min_atoms=0)
    assert split is not None
    moved = {a for a, _ in split.atoms}
    assert {"S0", "S2", "c_talker", "Nothing"} <= moved and "one sig" not in split.skeleton
    code = split_mod._COMMENT.sub("", split.skeleton)
    assert not moved & set(IDENTIFIER.findall(code))
    assert {"comps", "roles", "inputs", "plan_safe", "ok_steps"} <= set(split.bodies)
    assert "valid_states" not in split.bodies  # names no atom


@pytest.mark.parametrize("min_atoms", [0, 10**9])
def test_small_plans_judged_in_two_parts_or_as_text_agree(min_atoms: int, bridge: AlloyBridge,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(split_mod, "MIN_ATOMS", min_atoms)
    system, safe, early = _chatter_states()
    verdict = alloy_plan_verdict(system, safe, bridge=bridge)
    assert verdict.valid == (True, True, True) and verdict.steps == (("degrade",), ("detach",))
    refused = alloy_plan_verdict(system, early, bridge=bridge)  # evaluated in the counterexample
    assert refused.valid == (True, False) and refused.steps == ((),)


def test_a_generated_plan_and_its_broken_copy_get_the_same_verdicts_both_ways(
        bridge: AlloyBridge, monkeypatch: pytest.MonkeyPatch, tmp_path: "object") -> None:
    path = f"{tmp_path}/fanin.arch"
    with open(path, "w", encoding="utf-8") as f:
        f.write(generate("fanin", 40, 0, version=True))
    system = load([path])
    plan = plan_replace(system, hub_component("fanin", 40), "hub_v2")
    states = plan.states[:6]
    broken = list(states)
    broken[3] = Configuration(states[3].components, states[3].degraded, states[0].roles - states[3].roles)
    text, _ = render_plan(system, states)
    split = split_module(text)
    assert split is not None  # large enough to be split by default
    assert bridge._split_world(split, "plan.als").extra_sigs  # in two parts, not by the fallback
    verdicts = []
    for min_atoms in (split_mod.MIN_ATOMS, 10**9):
        monkeypatch.setattr(split_mod, "MIN_ATOMS", min_atoms)
        ok, bad = (alloy_plan_verdict(system, s, bridge=bridge) for s in (states, broken))
        verdicts.append(((ok.valid, ok.steps), (bad.valid, bad.steps)))
    assert verdicts[0] == verdicts[1]
    (ok_valid, ok_steps), (bad_valid, bad_steps) = verdicts[0]
    assert all(ok_valid) and all(ok_steps)
    assert not (all(bad_valid) and all(bad_steps))


def test_an_instance_module_in_two_parts_names_the_same_failures(bridge: AlloyBridge,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    bad = next(e for e in EXAMPLES if e.name == "chatter_slow").file
    system = load([bad])
    config = Configuration.initial(system)
    module, _ = render_instance(system, config)

    def failing() -> tuple[bool, set[tuple[str, ...]]]:
        (outcome,) = bridge.run({"instance.als": module}, "instance.als", "Valid", constants=True)
        return outcome.satisfiable, set(outcome.eval("unsatisfied")) if outcome.satisfiable else set()

    monkeypatch.setattr(split_mod, "MIN_ATOMS", 0)
    split = failing()
    monkeypatch.setattr(split_mod, "MIN_ATOMS", 10**9)
    text = failing()
    assert text[0] and text[1] and split == text
    assert not alloy_verdict(system, config, bridge=bridge).valid


def test_an_error_is_reported_at_its_place_in_the_text(bridge: AlloyBridge,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(split_mod, "MIN_ATOMS", 0)
    system, safe, _ = _chatter_states()
    text, _ = render_plan(system, safe)
    at = text.index("fun comps: System -> Component {\n") + len("fun comps: System -> Component {\n")
    broken = text[:at] + "  no_such_atom +" + text[at:]
    line = broken[:at].count("\n") + 1
    with pytest.raises(AlloyError) as err:
        bridge.run({"plan.als": broken}, "plan.als", "PlanSafe")
    assert err.value.line == line


def test_a_reused_skeleton_serves_each_module_with_exactly_its_own_atoms(bridge: AlloyBridge,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """Modules with the same skeleton share one parse of it; each sees only its own atoms
    and gets the verdict of a fresh parse, in any order."""
    monkeypatch.setattr(split_mod, "MIN_ATOMS", 0)
    system, safe, early = _chatter_states()
    texts = {name: render_plan(system, states)[0] for name, states in (("safe", safe), ("early", early))}
    splits = {name: split_module(text, min_atoms=0) for name, text in texts.items()}
    assert split_mod.skeleton_key(splits["safe"].skeleton) == split_mod.skeleton_key(splits["early"].skeleton)

    def fresh_sigs(name: str) -> list[str]:
        bridge._skeletons.clear()
        return sorted(str(s.label) for s in bridge._split_world(splits[name], "plan.als").sigs())

    alone = {name: fresh_sigs(name) for name in texts}
    assert alone["safe"] != alone["early"]  # three states against two
    for name in ("safe", "early", "safe", "early"):
        world = bridge._split_world(splits[name], "plan.als")
        assert world.skeleton is not None and world.skeleton.generation > 0  # the parse was reused
        assert sorted(str(s.label) for s in world.sigs()) == alone[name]
    for _ in range(2):
        verdict = alloy_plan_verdict(system, safe, bridge=bridge)
        assert verdict.valid == (True, True, True) and verdict.steps == (("degrade",), ("detach",))
        refused = alloy_plan_verdict(system, early, bridge=bridge)
        assert refused.valid == (True, False) and refused.steps == ((),)


def test_a_solution_is_not_evaluated_after_its_skeleton_serves_another_module(
        bridge: AlloyBridge, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(split_mod, "MIN_ATOMS", 0)
    system, safe, early = _chatter_states()
    (outcome,) = bridge.run({"plan.als": render_plan(system, early)[0]}, "plan.als", "Verdict")
    assert outcome.eval("valid_states")  # current: evaluated
    bridge.run({"plan.als": render_plan(system, safe)[0]}, "plan.als", "PlanSafe")
    assert outcome.eval("valid_states")  # evaluated while current: kept
    with pytest.raises(AlloyError, match="replaced by a later one"):
        outcome.eval("ok_steps")


def test_a_body_written_as_the_placeholder_is_not_left_from_the_previous_module(
        bridge: AlloyBridge, monkeypatch: pytest.MonkeyPatch) -> None:
    """Module B's `f` is empty, which is how module A's hollowed `f` reads in A's skeleton:
    the two skeletons read the same, but B must not judge A's body."""
    monkeypatch.setattr(split_mod, "MIN_ATOMS", 0)
    head = "module m\nabstract sig X {}\none sig x1, x2 extends X {}\n"
    a = head + "fun f: set X {\n  x1\n}\ncheck C { no f } expect 0\n"
    b = head + "fun f: set X {\n  none\n}\ncheck C { no f } expect 0\n"
    sa, sb = split_module(a), split_module(b)
    assert sa is not None and sb is not None and sa.skeleton == sb.skeleton and "f" in sa.bodies
    for _ in range(2):
        assert [o.satisfiable for o in bridge.run({"m.als": a}, "m.als")] == [True]
        assert [o.satisfiable for o in bridge.run({"m.als": b}, "m.als")] == [False]
