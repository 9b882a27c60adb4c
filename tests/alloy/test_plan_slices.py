"""Alloy verification of plans on slices of their architecture (checker.planning.slicing):
the lean slice, the full slice and the whole architecture give the same verdict, on sound
plans and on broken ones; a plan too large for the analyzer is not shown as verified."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from bench.gen import generate, hub_component
from checker.alloy import AlloyBridge
from checker.cli.main import main
from checker.planning import Plan
from checker.planning.alloy_verify import _window, alloy_evidence
from checker.planning.slicing import PlanSlicer, affected, slice_plan, stable_connectors
from tests.support.plans import break_state, hub_plan


@pytest.mark.parametrize("shape", ["fanin", "chain", "tree"])
def test_lean_full_and_whole_agree_on_a_sound_plan(shape: str, bridge: AlloyBridge) -> None:
    plan = hub_plan(shape, 40)
    lean = alloy_evidence(plan)
    assert lean["valid"], lean["reason"]
    assert lean["slice"]["kind"] == "lean"
    whole = alloy_evidence(plan, slice_=False)
    assert whole["valid"], whole["reason"]
    # the lean slice left out the readers of the connectors that stay satisfied
    assert len(affected(plan, frozenset(stable_connectors(plan)))) <= len(affected(plan))


def test_fanin_readers_of_a_hub_replaced_make_before_break_are_left_out(bridge: AlloyBridge) -> None:
    plan = hub_plan("fanin", 60)
    stable = stable_connectors(plan)
    assert stable, "make-before-break keeps the hub's topics satisfied"
    lean = slice_plan(plan, lean=True)
    full = slice_plan(plan)
    assert len(lean.system.components) < len(full.system.components)
    assert set(lean.stable) == stable and not full.stable


@pytest.mark.parametrize("shape", ["fanin", "chain"])
def test_a_broken_plan_is_refused_by_every_slice(shape: str, bridge: AlloyBridge) -> None:
    plan = hub_plan(shape, 40)
    broken = break_state(plan, len(plan.states) // 2)
    lean = alloy_evidence(broken)
    whole = alloy_evidence(broken, slice_=False)
    assert not lean["valid"] and not whole["valid"]
    assert lean["reason"] and whole["reason"]


def test_a_plan_too_large_for_the_analyzer_is_not_shown_as_verified(tmp_path: "object",
                                                                      monkeypatch: pytest.MonkeyPatch,
                                                                      bridge: AlloyBridge) -> None:
    import os

    import checker.planning.alloy_verify
    monkeypatch.setattr(checker.planning.alloy_verify, "MODULE_BUDGET", 10)
    path = os.path.join(str(tmp_path), "dag.arch")
    with open(path, "w") as f:
        f.write(generate("dag", 30, 0, version=True))
    hub = hub_component("dag", 30)
    result = CliRunner().invoke(main, ["plan", "replace", hub, "--with", hub + "_v2", "-f", path])
    assert result.exit_code == 2, result.output       # not answered, so not "unsafe" (docs/exit-codes.md)
    assert "RC303" in result.output and "Alloy could not verify the plan" in result.output
    assert "--no-alloy" in result.output
    result = CliRunner().invoke(main, ["plan", "replace", hub, "--with", hub + "_v2", "-f", path, "--no-alloy"])
    assert result.exit_code == 0, result.output
    # the gate does not call a plan it could not verify unsafe either: the hub's new run line is a new version
    old, new = (os.path.join(str(tmp_path), name) for name in ("old.arch", "new.arch"))
    text = generate("dag", 30, 0)
    with open(old, "w") as f:
        f.write(text)
    with open(new, "w") as f:
        f.write(text.replace(f"-r __node:={hub}\"", f"-r __node:={hub} --v2\""))
    result = CliRunner().invoke(main, ["gate", "--base", old, "--head", new, "--output-format", "json"])
    assert result.exit_code == 2, result.output
    assert json.loads(result.stdout)["diagnostics"][0]["code"] == "RC303"


def test_a_long_plan_is_verified_in_windows_with_the_whole_verdict(monkeypatch: pytest.MonkeyPatch,
                                                                    bridge: AlloyBridge) -> None:
    import checker.planning.alloy_verify

    plan = hub_plan("dag", 40)
    monkeypatch.setattr(checker.planning.alloy_verify, "WINDOW_BUDGET", 200)
    seen: list[str] = []
    windows = alloy_evidence(plan, progress=seen.append)
    assert windows["valid"], windows["reason"]
    assert windows["slice"]["windows"] > 2
    assert seen[0] == f"verifying {len(plan.steps)} steps in {windows['slice']['windows']} windows in the Alloy Analyzer…"
    assert alloy_evidence(plan, slice_=False)["valid"]
    # a state broken in a later window is found there, and named by its place in the plan: the
    # step into it is no longer its effect
    index = len(plan.states) - 3
    broken = alloy_evidence(break_state(plan, index))
    assert not broken["valid"]
    assert broken["reason"].startswith(f"step {index} ("), broken["reason"]


def test_the_plan_evaluated_agrees_with_its_module_solved(bridge: AlloyBridge) -> None:
    """A plan evaluated as an instance (alloy_plan_verdict) is judged as its plan module
    (render_plan), roles ternary or binary, is by the SAT solver: `check PlanSafe`."""
    from checker.alloy import alloy_plan_verdict
    from codegen.alloy import render_plan

    plan = hub_plan("chain", 12)
    for states, safe in ((plan.states, True), (break_state(plan, 3).states, False)):
        evaluated = alloy_plan_verdict(plan.system, states, bridge=bridge)
        for binary in (False, True):
            text, _ = render_plan(plan.system, states, binary=binary)
            (outcome,) = bridge.run({"plan.als": text}, "plan.als", "PlanSafe", constants=True)
            assert not outcome.satisfiable is evaluated.ok is safe, (binary, safe)
        assert all(evaluated.valid) is safe


def test_a_refuted_lean_window_is_decided_on_narrower_full_windows(monkeypatch: pytest.MonkeyPatch,
                                                                    bridge: AlloyBridge) -> None:
    """Alloy refuting every lean slice (as it may, for what a lean slice leaves out): the
    full slices decide, on windows narrow enough for them, and the plan is verified."""
    import checker.planning.alloy_verify as ap

    plan = hub_plan("fanin", 60)
    assert slice_plan(plan, lean=True).stable
    real = ap._judge

    def lean_refuted(plan: Plan, target: Plan, *args: object, **kw: object) -> tuple[str, float, str]:
        if target.stable:
            return "refuted on the lean slice", 0.0, ""
        return real(plan, target, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(ap, "_judge", lean_refuted)
    monkeypatch.setattr(ap, "_judge_at_once", lambda plan, windows: [(False, 0.0, "")] * len(windows))
    monkeypatch.setattr(ap, "WINDOW_BUDGET", 600)
    ev = alloy_evidence(plan)
    assert ev["valid"], ev["reason"]
    assert ev["slice"]["kind"] == "full" and ev["slice"]["windows"] > 1


def test_a_step_beyond_the_analyzer_is_not_run_rather_than_retried_forever(monkeypatch: pytest.MonkeyPatch,
                                                                           bridge: AlloyBridge) -> None:
    import checker.planning.alloy_verify as ap
    from checker.alloy.errors import AlloyError

    def too_many_atoms(*args: object, **kw: object) -> tuple[str, float, str]:
        raise AlloyError("Translation capacity exceeded.")

    monkeypatch.setattr(ap, "_judge", too_many_atoms)
    monkeypatch.setattr(ap, "_judge_at_once", lambda plan, windows: [])   # as when the batch fails
    ev = alloy_evidence(hub_plan("chain", 12))
    assert ev["verdict"] == "not run" and "step 1 " in ev["reason"], ev


@pytest.mark.parametrize("shape", ["dag", "fanin", "cycle"])
def test_window_slices_read_from_the_whole_plan_are_the_slices(shape: str) -> None:
    """PlanSlicer reads the plan's attachments once and each window's from them: every
    window's slice (lean and full) and core are those read from the window alone."""
    plan = hub_plan(shape, 60)
    slicer = PlanSlicer(plan)
    n = len(plan.steps)
    windows = [(k, w) for w in (1, 3, 7) for k in range(0, n, w)] + [(0, n)]
    for k, width in windows:
        window = _window(plan, k, width)
        for lean in (True, False):
            alone = slice_plan(window, lean=lean)
            shared, core = slicer.slice(window, lean=lean)
            assert shared.states == alone.states and shared.system == alone.system and shared.stable == alone.stable
            assert core == affected(window, frozenset(alone.stable))
