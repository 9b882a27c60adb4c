"""The slices of one check judged by two analyzers (checker/alloy/parallel.py)."""
from __future__ import annotations

import pytest

from bench.gen import generate
from checker.alloy import AlloyBridge, alloy_verdict
from checker.alloy.parallel import ENV, MIN_SLICES, Helper, helpers_wanted
from checker.config import Configuration
from checker.engines import python_failing
from checker.semantics import evaluate
from reconf_dsl.loader import load_text


def test_a_helper_process_judges_slices_and_the_verdict_is_the_same(monkeypatch: pytest.MonkeyPatch,
                                                                     bridge: AlloyBridge) -> None:
    system = load_text(generate("fanin", 1000, 1, unsafe=True), "big.arch")
    config = Configuration.initial(system)
    expected = python_failing(evaluate(system, config))
    assert expected, "the generated system has one violated assumption"
    monkeypatch.delenv(ENV, raising=False)
    together = alloy_verdict(system, config)
    assert together.processes == 2 and len(together.texts) >= MIN_SLICES
    assert (together.valid, together.unsatisfied) == (False, expected)
    monkeypatch.setenv(ENV, "1")
    alone = alloy_verdict(system, config)
    assert (alone.processes, alone.helped) == (1, 0)
    assert (alone.valid, alone.unsatisfied, alone.texts) == (together.valid, together.unsatisfied, together.texts)


def test_slices_a_dead_helper_had_taken_are_judged_here() -> None:
    helper = Helper("sat4j", "instance.als")
    try:
        helper.proc.kill()
        helper.proc.join(5)
        with helper.counter.get_lock():
            helper.counter.value = 2          # as if it had taken slices 0 and 1, then died
        judged_here: list[int] = []

        def mine(i: int):  # type: ignore[no-untyped-def]
            judged_here.append(i)
            return (False, [], 0.0, 0.0)
        out, helped = helper.judge_all(["a", "b", "c", "d"], mine)
        assert sorted(out) == [0, 1, 2, 3] and helped == 0
        assert sorted(judged_here) == [0, 1, 2, 3]
    finally:
        helper.close()


def test_a_helper_only_where_it_pays(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setattr("os.cpu_count", lambda: 2)
    assert helpers_wanted(MIN_SLICES) and not helpers_wanted(MIN_SLICES - 1)
    monkeypatch.setattr("os.cpu_count", lambda: 1)
    assert not helpers_wanted(1000)
    monkeypatch.setattr("os.cpu_count", lambda: 2)
    monkeypatch.setenv(ENV, "1")
    assert not helpers_wanted(1000)
