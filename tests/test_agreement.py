"""Python and Alloy must give the same verdict — and the same failing assumptions — on every
generated architecture and configuration (the real Alloy jar through JPype)."""
from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from checker.alloy import alloy_verdict
from checker.alloy.engines import python_failing
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl import ir
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES
from tests.support.semantic_strategies import configured

pytestmark = pytest.mark.alloy   # every test here asks the real Alloy Analyzer


@given(configured())
@settings(max_examples=220, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_python_and_alloy_agree(case: tuple[ir.System, Configuration]) -> None:
    system, config = case
    ev = evaluate(system, config)
    verdict = alloy_verdict(system, config)
    assert verdict.valid == ev.valid
    assert tuple(sorted(verdict.unsatisfied)) == python_failing(ev)


def test_agree_on_every_example() -> None:
    for ex in EXAMPLES:
        system = load([ex.file])
        config = Configuration.initial(system)
        assert alloy_verdict(system, config).valid == ex.safe, ex.name
        assert evaluate(system, config).valid == ex.safe


@given(configured())
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_slices_give_the_whole_modules_verdict(case: tuple[ir.System, Configuration]) -> None:
    """Judged in slices of one or two components (each with the connectors it reads and
    only the outputs publishing on them), a configuration gets the same verdict and the
    same failing assumptions as in one module, and as the Python engine."""
    system, config = case
    whole = alloy_verdict(system, config, slice_size=10_000)
    for size in (1, 2):
        sliced = alloy_verdict(system, config, slice_size=size)
        assert sliced.valid == whole.valid
        assert sliced.unsatisfied == whole.unsatisfied
    assert tuple(sorted(whole.unsatisfied)) == python_failing(evaluate(system, config))


def test_one_thread_or_three_the_same_verdict(monkeypatch: pytest.MonkeyPatch, tmp_path: "object") -> None:
    """The slices of a large configuration judged on one thread or on three at once (lean
    slices, judged again with every publisher when not valid): the same verdict and failing
    assumptions, the Python engine's."""
    import pathlib

    from bench.gen import generate, hub_component
    from checker.semantic_model.semantics import witnesses

    path = pathlib.Path(str(tmp_path)) / "fanin.arch"
    path.write_text(generate("fanin", 400, 5), encoding="utf-8")
    system = load([str(path)])
    initial = Configuration.initial(system)
    gone = {c.name for i, c in enumerate(system.components) if i % 9 == 4} | {hub_component("fanin", 400)}
    config = Configuration(initial.components - gone, initial.degraded,
                           frozenset(r for r in initial.roles if r[1] not in gone))
    expected = python_failing(evaluate(system, config))
    assert expected
    for threads in ("1", "3"):
        monkeypatch.setenv("RECONF_ALLOY_THREADS", threads)
        verdict = alloy_verdict(system, config, keep=witnesses(system, config, 16))
        assert (verdict.valid, verdict.unsatisfied) == (False, expected), threads
        assert verdict.threads == int(threads) and len(verdict.texts) > 3
