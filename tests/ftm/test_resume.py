"""A recovery's plan on an FTM resumes the crash detector and the recovery last
(checker/ftm/resume.py, docs/ftm.md#resuming-the-watchers-last): armed while the request path was
still suspended, a detector took the primary, busy with the queue the suspension built, for
crashed in the middle of a recovery (`bench_faults` seed 76, which this test replays in the model:
the PBR → LFR transition interrupted at step 24 by the death of the backup's new Before, then
`reconf recover --back`)."""
from __future__ import annotations

import os

from checker.ftm.resume import NOTE, watchers, watchers_last
from checker.ftm.transition import parse_ftm, plan_transition, with_ftm
from checker.planning.plan import Plan
from checker.planning.recovery import plan_recovery
from checker.semantic_model.config import Configuration
from reconf_dsl.loader import load
from tests.examples_table import ROOT

EXAMPLE = os.path.join(ROOT, "examples", "ftm", "client_server_pbr_tr.arch")
KILLED = "server__r1_dup_before@new"


def interrupted() -> tuple[Plan, Configuration]:
    """The transition's plan, and what its step 24 left with KILLED dead."""
    plan = plan_transition(with_ftm(load([EXAMPLE]), "server", parse_ftm("PBR")), "server", "LFR").plan
    at = plan.states[24]
    assert KILLED in at.components
    return plan, Configuration(at.components - {KILLED}, frozenset(d for d in at.degraded if d[0] != KILLED),
                               frozenset(r for r in at.roles if r[1] != KILLED))


def test_the_watchers_are_the_detector_and_the_recovery() -> None:
    plan, _ = interrupted()
    assert watchers(plan.system) == {("server__r1_cd", "detect"), ("server__recovery", "recover")}


def test_a_recovery_back_resumes_them_last_verified() -> None:
    plan, seen = interrupted()
    plain = plan_recovery(plan.system, seen, plan.states[0], "default")
    said = [a.describe() for a in plain.steps]
    assert said.index("upgrade server__r1_cd.detect") < said.index("upgrade server__proxy.relay")   # armed early
    back = plan_recovery(plan.system, seen, plan.states[0], "default", reorder=watchers_last)
    assert [a.describe() for a in back.steps[-2:]] == ["upgrade server__r1_cd.detect", "upgrade server__recovery.recover"]
    assert sorted(a.describe() for a in back.steps) == sorted(said)
    assert NOTE in back.notes and back.states[-1] == plain.states[-1] == plan.states[0]
