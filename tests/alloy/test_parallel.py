"""The slices of one check judged by two analyzers (checker/alloy/parallel.py)."""
from __future__ import annotations

import pytest

from bench.gen import generate
from checker.alloy import AlloyBridge
from checker.alloy.engines import python_failing
from checker.alloy.instance import slices
from checker.alloy.parallel import ENV, MIN_MODULES, Helper, Job, Judged, helpers_wanted, judge_many
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from codegen.alloy import render_instance
from reconf_dsl.loader import load_text


def test_a_helper_process_judges_modules_and_the_verdicts_are_the_same(monkeypatch: pytest.MonkeyPatch,
                                                                        bridge: AlloyBridge) -> None:
    """Many modules (a plan's windows; here a configuration's slices as instance modules)
    judged by this process and a helper give the verdicts this process alone gives."""
    system = load_text(generate("fanin", 1000, 1, unsafe=True), "big.arch")
    config = Configuration.initial(system)
    assert python_failing(evaluate(system, config)), "the generated system has one violated assumption"
    work = [Job("instance.als", render_instance(system, config, focus=f)[0], "Valid")
            for f in slices(system, config, 32) or []]
    monkeypatch.delenv(ENV, raising=False)
    together, processes, helped = judge_many(work, "glucose")
    assert processes == 2 and len(work) >= MIN_MODULES
    monkeypatch.setenv(ENV, "1")
    alone, processes, helped = judge_many(work, "glucose")
    assert (processes, helped) == (1, 0)
    assert [j.satisfiable for j in alone] == [j.satisfiable for j in together] and sum(j.satisfiable for j in alone) == 1


def test_modules_a_dead_helper_had_taken_are_judged_here() -> None:
    helper = Helper("sat4j")
    try:
        helper.proc.kill()
        helper.proc.join(5)
        judged_here: list[int] = []

        def mine(i: int) -> Judged:
            if not judged_here:
                with helper.counter.get_lock():
                    helper.counter.value += 2     # as if the helper had taken two, then died
            judged_here.append(i)
            return Judged(False, {}, 0.0, 0.0)
        work = [Job("m.als", t, "Valid") for t in "abcd"]
        out, helped = helper.judge_all(work, mine)
        assert len(out) == 4 and helped == 0
        assert sorted(judged_here) == [0, 1, 2, 3] and judged_here[:2] == [0, 3]
        again, _ = helper.judge_all(work[:2], mine)      # a later batch of the same helper
        assert len(again) == 2
    finally:
        helper.close()


def test_a_helper_only_where_it_pays(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setattr("os.cpu_count", lambda: 2)
    assert helpers_wanted(MIN_MODULES) and not helpers_wanted(MIN_MODULES - 1)
    monkeypatch.setattr("os.cpu_count", lambda: 1)
    assert not helpers_wanted(1000)
    monkeypatch.setattr("os.cpu_count", lambda: 2)
    monkeypatch.setenv(ENV, "1")
    assert not helpers_wanted(1000)


def test_plan_windows_judged_by_two_analyzers_give_the_same_evidence(monkeypatch: pytest.MonkeyPatch,
                                                                     bridge: AlloyBridge) -> None:
    import checker.alloy.parallel
    import checker.planning.alloy_verify
    from checker.planning.alloy_verify import alloy_evidence
    from tests.support.plans import break_state, hub_plan

    plan = hub_plan("dag", 40)
    monkeypatch.setattr(checker.planning.alloy_verify, "WINDOW_BUDGET", 200)
    monkeypatch.setattr(checker.alloy.parallel, "MIN_MODULES", 2)
    monkeypatch.delenv(ENV, raising=False)
    together = alloy_evidence(plan)
    index = len(plan.states) - 3
    broken_together = alloy_evidence(break_state(plan, index))
    monkeypatch.setenv(ENV, "1")
    alone = alloy_evidence(plan)
    assert together["valid"] and together["slice"]["windows"] > 2
    assert (together["module_hash"], together["slice"]) == (alone["module_hash"], alone["slice"])
    assert not broken_together["valid"]
    assert broken_together["reason"] == alloy_evidence(break_state(plan, index))["reason"]
