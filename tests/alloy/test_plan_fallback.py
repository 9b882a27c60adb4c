"""The planners' fallback with the Alloy Analyzer: the plan the exhaustive search finds after
default and paper fail is verified by Alloy, and the Alloy planner answers what the search
could not decide."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from bench.gen import generate
from checker.alloy import AlloyBridge
from checker.cli.main import main
from checker.planning import Fallback, plan_with_fallback, strategies
from checker.planning.exhaustive import Budget
from checker.planning.operations import replace_problem
from checker.planning.plan import NoSafePlan, Problem
from tests.support.systems import talker_system


def test_removing_the_tree_root_is_planned_and_verified_by_alloy(bridge: AlloyBridge, tmp_path: Path) -> None:
    path = tmp_path / "tree.arch"
    path.write_text(generate("tree", 10, 2, version=True), encoding="utf-8")
    r = CliRunner().invoke(main, ["plan", "remove", "c0", "-f", str(path), "--output-format", "json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["plan"]["strategy"] == "exhaustive"
    assert [a["strategy"] for a in doc["plan"]["attempts"]] == ["default", "paper"]
    alloy = doc["evidence"]["alloy"]
    assert alloy["valid"] is True and alloy["states"] == 13 and alloy["transitions"] == 12


def test_the_alloy_planner_answers_what_the_search_could_not_decide(bridge: AlloyBridge,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    # the search starts from the default strategy's plan where there is one, and then always
    # answers: here the default is made to find none, so the search has only its budget (none)
    def none(problem: Problem) -> Any:
        raise NoSafePlan(["default: found no plan (as this test has it)"])
    monkeypatch.setattr(strategies, "_default", none)
    problem = replace_problem(talker_system(), "talker", "talker_v2")
    plan = plan_with_fallback(problem, "exhaustive", Fallback(alloy=True, max_steps=6,
                                                               budget=Budget(states=0, seconds=0)))
    assert plan.strategy == "alloy"
    assert [(a.strategy, a.outcome) for a in plan.attempts] == [("exhaustive", "gave up")]
    assert plan.goal.reached(plan.states[-1]) and plan.verification == "full"
