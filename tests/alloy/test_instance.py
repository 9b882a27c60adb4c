"""Instance modules: a concrete architecture and configuration as an Alloy module, judged
by the same semantics as the meta-model, agreeing with the Python engine."""
from __future__ import annotations

import random
import re
import time
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from checker.alloy import AlloyBridge, alloy_verdict
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from codegen.alloy import mangle, render_instance, union
from reconf_dsl import ir
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES

IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def python_verdict(system: ir.System, config: Configuration) -> tuple[bool, tuple[tuple[str, str, int], ...]]:
    ev = evaluate(system, config, explain=False)
    return ev.valid, tuple(sorted((r.component, r.functionality, r.index) for r in ev.unsatisfied))


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.name for e in EXAMPLES])
def test_examples_agree_with_python(bridge: AlloyBridge, example) -> None:  # type: ignore[no-untyped-def]
    system = load([example.file])
    config = Configuration.initial(system)
    verdict = alloy_verdict(system, config, bridge=bridge)
    assert verdict.valid == example.safe
    assert (verdict.valid, verdict.unsatisfied) == python_verdict(system, config)
    assert {f"{c}.{f}" for c, f, _ in verdict.unsatisfied} == set(example.unsatisfied)


def _variations(system: ir.System, rng: random.Random, n: int) -> list[Configuration]:
    base = Configuration.initial(system)
    funcs = sorted((c.name, f.name) for c in system.components for f in c.functionalities)
    out = []
    for _ in range(n):
        comps = frozenset(c for c in base.components if rng.random() < 0.85)
        degraded = frozenset(f for f in funcs if rng.random() < 0.3)
        roles = frozenset(r for r in base.roles if rng.random() < 0.7 and r[1] in comps)
        out.append(Configuration(comps, degraded, roles))
    return out


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.name for e in EXAMPLES])
def test_changed_configurations_agree_with_python(bridge: AlloyBridge, example) -> None:  # type: ignore[no-untyped-def]
    system = load([example.file])
    for config in _variations(system, random.Random(example.name), 4):
        verdict = alloy_verdict(system, config, bridge=bridge)
        assert (verdict.valid, verdict.unsatisfied) == python_verdict(system, config), config


def _odd_system(names: list[str]) -> ir.System:
    """A chain of components with the given names; each publishes to the next's topic."""
    msg = "Odd/msg"
    rate = ir.Rate(Fraction(10), "Hz")
    comps, conns = [], []
    for i, name in enumerate(names):
        ports = [ir.Port("out", "output", msg)]
        fports = ["out"]
        asms: tuple[ir.Predicate, ...] = ()
        if i > 0:
            ports.append(ir.Port("in", "input", msg, ir.Predicate(msg, rate)))
            fports.append("in")
            asms = (ir.Predicate(msg, rate),)
        func = ir.Functionality(
            name, tuple(fports),
            ir.Mode("normal", asms, (ir.Guarantee("out", ir.Predicate(msg, rate)),)),
            ir.Mode("degraded", (), (ir.Guarantee("out", ir.NOTHING),)))
        comps.append(ir.Component(name, tuple(ports), (func,)))
        if i > 0:
            conns.append(ir.Connector(f"/ns/{names[i - 1]}/topic", "topic", ir.Predicate(msg, rate),
                                      publishers=(ir.PortRef(names[i - 1], "out"),),
                                      subscribers=(ir.PortRef(name, "in"),)))
    return ir.System("odd", (ir.MessageType(msg, "odd/msg/Odd"),), (), tuple(comps), (), tuple(conns))


def test_keywords_and_odd_characters_make_a_valid_module(bridge: AlloyBridge) -> None:
    names = ["sig", "run", "open", "this", "ñandú", "a_b", "a", "b_c", "x y", "Int", "fun", "none"]
    system = _odd_system(names)
    config = Configuration.initial(system)
    text, name_map = render_instance(system, config)
    for atom in name_map:
        assert IDENT.match(atom), atom
    assert {m[1] for m in name_map.values() if m[0] == "component"} == set(names)
    verdict = alloy_verdict(system, config, bridge=bridge)
    assert verdict.valid
    # remove the first component's output from its topic: its successor loses its input
    first_topic = system.connectors[0].name
    broken = Configuration(config.components, config.degraded,
                           config.roles - {(first_topic, names[0], "out")})
    verdict = alloy_verdict(system, broken, bridge=bridge)
    assert (verdict.valid, verdict.unsatisfied) == (False, ((names[1], names[1], 0),))
    assert (verdict.valid, verdict.unsatisfied) == python_verdict(system, broken)


def test_large_architecture_is_fast(bridge: AlloyBridge) -> None:
    system = _odd_system([f"node{i}" for i in range(150)])
    config = Configuration.initial(system)
    start = time.perf_counter()
    verdict = alloy_verdict(system, config, bridge=bridge)
    assert verdict.valid
    assert time.perf_counter() - start < 20


def test_union_is_balanced() -> None:
    assert union([], "none") == "none"
    assert union(["a"], "none") == "a"
    assert union(["a", "b", "c", "d"], "none") == "((a + b) + (c + d))"


@settings(max_examples=200, deadline=None)
@given(st.text(min_size=1, max_size=8), st.text(min_size=1, max_size=8))
def test_mangling_is_injective_and_valid(a: str, b: str) -> None:
    ma, mb = mangle("component", a), mangle("component", b)
    assert IDENT.match(ma) and IDENT.match(mb)
    assert (ma == mb) == (a == b)
    assert mangle("port", a, b) != mangle("port", a + "_o_" + b) or a + "_o_" + b == a


def _module_valid(bridge: AlloyBridge, text: str) -> bool:
    """An instance module's `check Valid` solved: no counterexample means valid."""
    (outcome,) = bridge.run({"instance.als": text}, "instance.als", "Valid", constants=True)
    return not outcome.satisfiable


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.name for e in EXAMPLES])
def test_instance_modules_solved_agree_with_the_evaluation(example, bridge: AlloyBridge,  # type: ignore[no-untyped-def]
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """The instance module a user can open in the Analyzer (`reconf alloy`), its guarantees
    ternary or an atom each, solved by the SAT solver, gives the verdict that evaluating the
    configuration as an instance gives, in changed configurations too."""
    import codegen.alloy as gen

    system = load([example.file])
    for config in [Configuration.initial(system)] + _variations(system, random.Random(example.name), 2):
        evaluated = alloy_verdict(system, config, bridge=bridge)
        ternary, _ = render_instance(system, config)
        assert "fun nguar: Functionality -> Output -> Data" in ternary and "sig Guar" not in ternary
        with monkeypatch.context() as m:
            m.setattr(gen, "TERNARY_ATOMS", 0)
            atoms, _ = render_instance(system, config)
        assert "abstract sig Guar" in atoms
        assert _module_valid(bridge, ternary) == _module_valid(bridge, atoms) == evaluated.valid \
            == python_verdict(system, config)[0], config


def test_a_slice_near_the_ternary_limit_holds_guarantees_as_atoms(bridge: AlloyBridge) -> None:
    """The analyzer's universe has Int atoms besides the module's: a slice of the fan-in's
    hub with about 1,274 atoms must not get ternary guarantees (it would exceed what a
    ternary relation can index) and is judged as the Python engine judges it."""
    from bench.gen import generate
    from checker.alloy.instance import slices
    from reconf_dsl.loader import load_text

    system = load_text(generate("fanin", 736), "fanin.arch")
    config = Configuration.initial(system)
    sizes = [(len(names), "abstract sig Guar" in text)
             for text, names in (render_instance(system, config, focus=f) for f in slices(system, config) or [])]
    assert any(n > 1_240 and atoms for n, atoms in sizes)
    verdict = alloy_verdict(system, config, bridge=bridge)
    assert (verdict.valid, verdict.unsatisfied) == python_verdict(system, config)


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.name for e in EXAMPLES])
def test_slices_read_through_the_index_are_the_slices(example) -> None:  # type: ignore[no-untyped-def]
    """A check computes what every slice reads once (`slice_index`); each slice rendered
    through it is the text rendered from the whole system, in changed configurations too."""
    from checker.alloy.instance import slices
    from codegen.alloy import slice_index
    system = load([example.file])
    configs = [Configuration.initial(system)] + _variations(system, random.Random(example.name), 4)
    for config in configs:
        index = slice_index(system, config)
        for focus in slices(system, config, size=2) or []:
            assert render_instance(system, config, focus=focus, index=index) == \
                render_instance(system, config, focus=focus), (config, focus)


def test_a_wide_connector_is_shown_by_its_witness(bridge: AlloyBridge, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A slice may show a connector of many publishers by one that satisfies it: the verdicts
    and failing assumptions are the full slices', whether the lean slice holds or not."""
    from bench.gen import generate
    from checker.semantic_model.semantics import witnesses
    path = tmp_path / "fanin.arch"
    path.write_text(generate("fanin", 160, seed=2), encoding="utf-8")
    system = load([str(path)])
    base = Configuration.initial(system)
    keep = witnesses(system, base, 16)
    assert set(keep) == {"/hub/in0", "/hub/in1", "/hub/in2"} and all(len(w) == 1 for w in keep.values())
    lean, full = (alloy_verdict(system, base, bridge=bridge, keep=k) for k in (keep, None))
    assert lean.valid and full.valid
    # the hub's slice shows the three witnesses, not the 79 publishers: the largest slice shrinks
    outputs = re.compile(r'<tuple><atom label="c_c\d+"/><atom label="p_c\d+_o_o0"/></tuple>')
    assert max(len(outputs.findall(t)) for t in lean.texts) < max(len(outputs.findall(t)) for t in full.texts)
    # the hub loses one of its topics, and some publishers of another go: the lean slice of
    # the hub is not valid, and is judged again with every publisher
    gone = {c for k, c, _ in base.roles if k == "/hub/in2"}
    cut = Configuration(base.components - set(sorted(gone)[:20]), base.degraded,
                        frozenset(r for r in base.roles if r[0] != "/hub/in1" and r[1] not in sorted(gone)[:20]))
    keep = witnesses(system, cut, 16)
    lean, full = (alloy_verdict(system, cut, bridge=bridge, keep=k) for k in (keep, None))
    assert not lean.valid and (lean.valid, lean.unsatisfied) == (full.valid, full.unsatisfied) \
        == python_verdict(system, cut)
    assert any(u[0] == "hub" for u in lean.unsatisfied)


@pytest.mark.parametrize("name, valid", [("chatter.arch", True), ("chatter_slow.arch", False)])
def test_reconf_alloy_expects_what_the_configuration_is(bridge: AlloyBridge, tmp_path, name: str,  # type: ignore[no-untyped-def]
                                                        valid: bool) -> None:
    """`reconf alloy` of an unsafe configuration expects the counterexample (`expect 1`), says
    so in a comment, and the analyzer finds it: the GUI shows no unexpected outcome."""
    from click.testing import CliRunner

    from checker.cli.main import main
    from tests.examples_table import ROOT
    out = tmp_path / "system.als"
    r = CliRunner().invoke(main, ["alloy", f"{ROOT}/examples/{name}", "-o", str(out)])
    assert r.exit_code == 0, r.stderr
    text = out.read_text(encoding="utf-8")
    assert f"check Valid {{ valid }} expect {0 if valid else 1}" in text
    assert ("no counterexample is expected" if valid else "a counterexample is expected") in text
    (outcome,) = bridge.run({"instance.als": text}, "instance.als", "Valid", constants=True)
    assert outcome.satisfiable is not valid
