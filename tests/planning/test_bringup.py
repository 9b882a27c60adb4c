"""Bring-up and tear-down plans: from nothing to every bundled example's deployed configuration
and back, each state re-checked by the semantic engine the planners do not use."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from checker.planning import Fallback, NoPlanFound, NoSafePlan, verify
from checker.planning.bringup import EMPTY, plan_down, plan_up, up_state
from checker.semantic_model.semantics import evaluate
from reconf_dsl.loader import Sources, load

from ..examples_table import EXAMPLES

RECONF = [sys.executable, "-m", "checker"]
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_up_and_down_reach_their_ends_through_valid_states(ex) -> None:
    system = load([ex.file], Sources())
    target = up_state(system)
    degraded = {f"{c}.{f}" for c, f in target.degraded}
    assert degraded == set(ex.unsatisfied)                  # what cannot hold stays degraded, no more
    try:
        up = plan_up(system, fallback=Fallback())
    except (NoPlanFound, NoSafePlan) as e:                  # a publisher that can never serve its topic
        assert not ex.safe and "guarantees at best" in " ".join(e.reasons), e.reasons
        return
    assert up.states[0] == EMPTY and up.states[-1] == target
    assert [a.kind for a in up.steps].count("create") == len(system.components)
    down = plan_down(system, fallback=Fallback())
    assert down.states[0] == target and down.states[-1] == EMPTY
    for p in (up, down):
        verify(p.system, p.states[0], p.steps, p.goal, p.strategy, full=True)
        assert all(evaluate(p.system, s).valid for s in p.states)


def test_an_architecture_that_cannot_be_safe_is_not_brought_up(tmp_path: Path) -> None:
    script = tmp_path / "up.py"
    res = subprocess.run([*RECONF, "up", "examples/chatter_slow.arch", "--no-alloy", "-o", str(script)],
                         capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 1, res.stderr
    assert "talker.out guarantees at best String @ 5 Hz" in res.stderr
    assert not script.exists()


@pytest.mark.alloy
def test_up_writes_the_verified_script_and_applies_nothing(tmp_path: Path) -> None:
    script = tmp_path / "up.py"
    res = subprocess.run([*RECONF, "up", "examples/chatter.arch", "-o", str(script), "--output-format", "json"],
                         capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["evidence"]["alloy"]["valid"] is True and doc["evidence"]["alloy"]["states"] == 7
    assert [s["action"] for s in doc["plan"]["steps"]] == ["create", "upgrade", "attach", "create", "attach",
                                                           "upgrade"]
    dry = subprocess.run([sys.executable, str(script), "--dry-run"], capture_output=True, text=True)
    assert dry.returncode == 0 and "dry run: all 7 states are safe" in dry.stdout, dry.stdout + dry.stderr
