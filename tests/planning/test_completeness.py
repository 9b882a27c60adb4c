"""Planning is complete where a plan exists: a strategy that fails hands over to the next
(checker.planning.chain), and the exhaustive search decides (checker.planning.exhaustive)."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from bench.gen import build, generate, render
from checker.cli.main import main
from checker.planning import Fallback, NoPlanFound, Plan, plan_replace, plan_with_fallback
from checker.planning.exhaustive import Budget, Impossible, _astar, _Clock, _Space, exhaustive_search
from checker.planning.improve import cost
from checker.planning.operations import remove_problem, replace_problem
from checker.planning.plan import NoSafePlan, Problem, ready, settle, verify
from checker.planning.relaxed import reachable
from checker.semantic_model.actions import action_from_dict
from checker.semantic_model.config import Configuration
from reconf_dsl.loader import load, load_text
from tests.support.random_systems import random_system
from tests.support.systems import chain_system, talker_system


def arch(tmp_path: Path, shape: str, n: int, seed: int) -> str:
    path = tmp_path / f"{shape}_{n}_{seed}.arch"
    path.write_text(generate(shape, n, seed, version=True), encoding="utf-8")
    return str(path)


def test_removing_the_root_of_a_tree_is_planned_by_the_search_when_default_and_paper_find_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # c8.bk publishes on c0's topic and reads, through c2, c0's other topic: a cycle that both
    # greedy strategies tie themselves in
    path = arch(tmp_path, "tree", 10, 2)
    from checker.planning import strategies
    greedy: list[str] = []
    for name in ("default_steps", "paper_steps"):
        monkeypatch.setattr(strategies, name, lambda *a, _f=getattr(strategies, name), _n=name: (greedy.append(_n), _f(*a))[1])
    r = CliRunner().invoke(main, ["plan", "remove", "c0", "-f", path, "--no-alloy", "--output-format", "json"])
    # each greedy strategy ran once: the search, after them, does not look for their plans again
    assert sorted(greedy) == ["default_steps", "paper_steps", "paper_steps"], greedy
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    plan = doc["plan"]
    assert plan["strategy"] == "exhaustive" and plan["disruption"] == 107 and len(plan["steps"]) == 12
    assert [(a["strategy"], a["outcome"]) for a in plan["attempts"]] == [("default", "no plan"), ("paper", "no plan")]
    assert "no order of degrades is safe" in plan["attempts"][0]["reasons"][0]
    assert doc["evidence"]["python"]["valid"] is True
    (searched,) = [n for n in plan["notes"] if n.startswith("exhaustive:")]
    assert re.fullmatch(r"exhaustive: least disruptive, then fewest steps \(A\* over [\d,]+ configurations, "
                        r"\d+\.\d s\)", searched), searched
    text = CliRunner().invoke(main, ["plan", "remove", "c0", "-f", path, "--no-alloy"]).stderr
    assert "in 12 steps (strategy exhaustive; default and paper failed, see below)" in text
    assert "note: default: found no plan: detach c0.o1 from /c0/o1 needs" in text
    assert "note: paper: found no plan: cannot degrade c8.f1" in text
    # the document's own steps, checked again, every state judged in full
    system = load([path])
    steps = [action_from_dict(a) for a in plan["steps"]]
    goal = remove_problem(system, "c0").goal
    checked = verify(system, Configuration.initial(system), steps, settle(system, goal), "exhaustive", full=True)
    assert checked.disruption == 107 and checked.verification == "full"


def test_a_refused_plan_hands_over_to_the_next_strategy() -> None:
    problem = replace_problem(talker_system(), "talker", "talker_v2")
    refusals: list[str] = []

    def accept(p: Plan) -> str | None:
        refusals.append(p.strategy)
        return "refused here" if p.strategy == "default" else None

    plan = plan_with_fallback(problem, "default", Fallback(accept=accept))
    assert plan.strategy == "paper" and refusals == ["default", "paper"]
    assert [(a.strategy, a.outcome, a.reasons) for a in plan.attempts] == [("default", "refuted", ("refused here",))]
    assert plan.to_dict()["attempts"] == [{"strategy": "default", "outcome": "refuted", "reasons": ["refused here"]}]
    # asked for a strategy further down the chain, the earlier ones are not tried
    assert plan_with_fallback(problem, "exhaustive", Fallback()).strategy == "exhaustive"
    # without a fallback, a strategy plans alone: what it finds or why not
    with pytest.raises(NoSafePlan) as alone:
        plan_replace(chain_system(3, single=True, ring=True), "r0", "r0_v2", "default")
    assert not isinstance(alone.value, NoPlanFound)


def test_no_plan_says_which_search_proved_it_and_how(tmp_path: Path) -> None:
    # a ring: removing c9 needs c7 degraded first, which needs c8, which needs c9
    path = tmp_path / "cycle.arch"
    path.write_text(generate("cycle", 10, 0), encoding="utf-8")
    r = CliRunner().invoke(main, ["plan", "remove", "c9", "-f", str(path), "--no-alloy", "--output-format", "json"])
    assert r.exit_code == 1, r.output
    doc = json.loads(r.stdout)
    assert doc["verdict"] == "no-plan"
    assert [(a["strategy"], a["outcome"]) for a in doc["attempts"]] == [
        ("default", "no plan"), ("paper", "no plan"), ("exhaustive", "none exists")]
    assert doc["attempts"][-1]["proved_by"] == "relaxation"
    last = doc["reasons"][-1]
    assert last.startswith("exhaustive: no safe plan exists: c9 can never be removed: c9.i0 → /c8/o1 can never be "
                           "detached")
    assert "Proved by relaxing the search" in last and "each changed any number of times" in last
    # where the relaxation cannot tell, the search visits every reachable configuration
    with pytest.raises(NoPlanFound) as e:
        plan_replace(chain_system(3, single=True, ring=True), "r0", "r0_v2", fallback=Fallback())
    assert e.value.attempts[-1].how == "search"
    assert ("exhaustive: no safe plan exists: the search visited all 2 configurations reachable from the start by "
            "safe steps towards the target") in e.value.reasons[-1]


def _settled(shape: str, n: int, seed: int, op: str, who: str) -> Problem:
    """`op` ("replace" or "remove") of `who` in the generated system, its goal settled."""
    system = load_text(render(build(shape, n, seed), version_of=who), f"{shape}_{n}_{seed}.arch")
    return ready(replace_problem(system, who, f"{who}_v2") if op == "replace" else remove_problem(system, who))


def test_the_search_decides_problems_it_used_to_give_up_on() -> None:
    budget = Budget(seconds=20)
    # 100,000 configurations (57 s) without an answer before: the relaxation proves there is none
    p = _settled("cycle", 20, 0, "remove", "c0")
    with pytest.raises(Impossible) as e:
        exhaustive_search(p.system, p.start, p.goal, budget)
    assert e.value.how == "relaxation"
    assert e.value.reasons[0].startswith("exhaustive: no safe plan exists: c0 can never be removed: c0.o0 → /c0/o0 "
                                         "can never be detached")
    # 100,000 configurations (103 s) without an answer before: the optimum, 26, is the default's
    p = _settled("tree", 20, 0, "replace", "c19")
    search = exhaustive_search(p.system, p.start, p.goal, budget)
    assert search.optimal
    assert cost(p.system, p.start, search.steps, p.goal) == (26, 16)
    assert plan_replace(p.system, "c19", "c19_v2", "default").disruption == 26


def test_the_search_agrees_with_a_plain_uniform_cost_search_on_random_systems() -> None:
    """The pruning (relevant functionalities, steps taken at once), the bound and the relaxation
    lose nothing: against a uniform-cost search over every functionality's mode, the same
    optimum, a proof only where there is no plan, and a relaxation that never refuses one."""
    problems = [replace_problem(chain_system(n, single=True, ring=True), "r0", "r0_v2") for n in (3, 4)]
    for seed in range(60):
        s = random_system(seed, n=4, single_p=0.5)
        if s is not None:
            problems += [replace_problem(s, "c0", "c0_v2"), remove_problem(s, "c0"), remove_problem(s, "c1")]
    compared = proved = 0
    for problem in problems:
        try:
            p = ready(problem)
        except NoSafePlan:
            continue
        plain = _Space(p.system, p.start, p.goal, prune=False)
        ref, _ = _astar(plain, _Clock(Budget()), None, lambda c: (0, 0))
        optimum = None if ref is None else cost(p.system, p.start, ref, p.goal)
        for restricted in (False, True):
            relaxed = reachable(p.system, p.start, p.goal, restricted, _Space(p.system, p.start, p.goal).relevant)
            assert optimum is None or relaxed.possible, relaxed.missing
        try:
            search = exhaustive_search(p.system, p.start, p.goal)
        except Impossible:
            assert optimum is None, p.goal
            proved += 1
            continue
        assert search.optimal and cost(p.system, p.start, search.steps, p.goal) == optimum
        compared += 1
    assert compared >= 100 and proved >= 2


def test_the_search_starts_from_the_default_plan_and_never_returns_a_worse_one() -> None:
    """With the default strategy's plan as its incumbent, the search returns a plan at most as
    disruptive (the optimum, where its budget allows), and on a budget too small for A* it keeps
    that plan and says so."""
    from checker.planning.strategies import _default, solve
    p = _settled("tree", 20, 0, "replace", "c19")
    mine = _default(p)[0]
    known = cost(p.system, p.start, mine, p.goal)
    assert known is not None
    search = exhaustive_search(p.system, p.start, p.goal, Budget(seconds=20), incumbent=mine)
    assert search.optimal and search.visited == 0          # a plan exists: no reachability search
    found = cost(p.system, p.start, search.steps, p.goal)
    assert found is not None and found <= known
    starved = exhaustive_search(p.system, p.start, p.goal, Budget(states=1, seconds=0.0), incumbent=mine)
    assert starved.kept and not starved.optimal and starved.steps == mine
    assert "the default strategy's plan (disruption 26) is kept" in starved.note()
    assert "its budget ran out" in starved.note()
    # the strategy itself: never worse than the default's
    plan = solve(p, "exhaustive", Budget(states=1, seconds=0.0))
    assert (plan.disruption, len(plan.steps)) == known and any("is kept" in n for n in plan.notes)
