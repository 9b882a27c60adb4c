"""The benchmark generators produce architectures that parse and get the verdict they promise."""
from __future__ import annotations

import os
import re
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench.gen import SHAPES, generate, hub_component, main  # noqa: E402
from checker.semantic_model.config import Configuration  # noqa: E402
from checker.semantic_model.semantics import evaluate  # noqa: E402
from reconf_dsl.loader import load, load_text  # noqa: E402

N = 20


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("seed", [0, 1, 7])
def test_generated_system_is_safe(shape: str, seed: int) -> None:
    system = load_text(generate(shape, N, seed), "gen.arch")
    assert len(system.components) == N
    assert evaluate(system, Configuration.initial(system)).valid


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("seed", [0, 1, 7])
def test_unsafe_injects_a_rate_violation(shape: str, seed: int) -> None:
    system = load_text(generate(shape, N, seed, unsafe=True), "gen.arch")
    ev = evaluate(system, Configuration.initial(system))
    assert not ev.valid
    bad = ev.unsatisfied
    assert len({r.component for r in bad}) == 1, "one injected violation, in one component"
    texts = [link.text for r in bad for link in r.chain]
    too_low = [t for t in texts if "rate too low" in t]
    assert too_low, texts
    for t in too_low:    # the topic's rate, under the input's: "... @ 0.5 Hz: rate too low: 0.5 Hz < 1 Hz"
        m = re.fullmatch(r"topic /\S+ guarantees \w+ @ (\S+ k?Hz): rate too low: \1 < \S+ Hz", t)
        assert m, t


@pytest.mark.parametrize("shape", SHAPES)
def test_generation_is_deterministic_and_seeded(shape: str) -> None:
    assert generate(shape, N, 3) == generate(shape, N, 3)
    if shape != "fanin":  # fanin's wiring is fixed; only rates and extra outputs vary
        assert generate(shape, N, 3) != generate(shape, N, 4)


@pytest.mark.parametrize("shape", SHAPES)
def test_hub_and_its_replacement_version(shape: str) -> None:
    hub = hub_component(shape, N)
    system = load_text(generate(shape, N, 0, version=True), "gen.arch")
    assert system.component(hub) is not None
    assert [v.replaces for v in system.versions] == [hub]
    assert evaluate(system, Configuration.initial(system)).valid


def test_shapes_have_their_structure() -> None:
    fanin = load_text(generate("fanin", N, 0), "gen.arch")
    assert max(len(c.publishers) for c in fanin.connectors) >= (N - 1) // 2 // 3
    for shape in SHAPES:
        system = load_text(generate(shape, N, 0), "gen.arch")
        redundant = [c for c in system.connectors if len(c.publishers) > 1]
        assert redundant, f"{shape}: some topic has redundant publishers"
        assert system.environment
        for c in system.components:
            assert 1 <= len(c.outputs) <= 3 and len(c.inputs) <= 3
            for f in c.functionalities:
                assert f.normal is not None and f.degraded is not None
        units = {p.assumption.rate.unit for c in system.components for p in c.inputs if p.assumption and p.assumption.rate}
        assert len(units) >= 2, f"{shape}: rates in several units, got {units}"


def test_cli_writes_a_file(tmp_path: "os.PathLike[str]") -> None:
    out = os.path.join(str(tmp_path), "chain.arch")
    assert main(["--shape", "chain", "--n", "12", "--seed", "2", "-o", out]) == 0
    system = load([out])
    assert evaluate(system, Configuration.initial(system)).valid
    out2 = os.path.join(str(tmp_path), "bad.arch")
    assert main(["--shape", "cycle", "--n", "12", "--unsafe", "-o", out2]) == 0
    system = load([out2])
    assert not evaluate(system, Configuration.initial(system)).valid


def test_rejects_unknown_shape() -> None:
    with pytest.raises(ValueError):
        generate("star", 10, 0)
