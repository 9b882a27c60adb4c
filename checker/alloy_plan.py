"""The Alloy half of a plan's verification: every state valid, every step an instance of the
action the plan says it is, with that action's preconditions (the meta-model's predicates)."""
from __future__ import annotations

import hashlib
from typing import Any

from .alloy.errors import AlloyError
from .planning import Plan


# states x components of a plan module past which it is not run (about a minute of work here)
MODULE_BUDGET = 40_000


def _not_run(plan: Plan, solver: str, seconds: float, reason: str) -> dict[str, Any]:
    return {"engine": "alloy", "valid": False, "verdict": "not run", "reason": reason, "states": len(plan.states),
            "transitions": len(plan.steps), "solver": solver, "seconds": round(seconds, 3)}


def alloy_evidence(plan: Plan, solver: str = "glucose", slice_: bool = True) -> dict[str, Any]:
    """Evidence for the plan document; `valid` is False (with a `reason`) when Alloy refutes it.

    With `slice_` (the default), the plan module holds only the part of the architecture the
    plan can affect (`checker.planning.slicing`), lean first (readers of connectors that stay
    satisfied left out, one witness per connector among the untouched publishers), then, if
    Alloy refutes the lean slice, the full one, whose verdict stands. The assumptions of every
    other component read nothing the plan changes, and Alloy judges them once, in the first
    configuration. A plan that must keep proxies serving (`Plan.serving`) is also checked
    lossless in every state. Raises the bridge's AlloyUnavailable when Java or the jar is
    missing."""
    from .alloy import alloy_verdict
    from .alloy.bridge import AlloyBridge
    from .planning.slicing import affected, slice_plan

    seconds = 0.0
    texts: list[str] = []
    target, reason, tried = plan, "", []
    for lean in ((True, False) if slice_ and plan.states else (None,)):
        target = slice_plan(plan, lean=lean) if lean is not None else plan
        comps = len(target.system.components) + len(target.system.versions)
        if len(target.states) * comps > MODULE_BUDGET:
            # the module lists every state: past this, the analyzer takes minutes or fails
            return _not_run(plan, solver, seconds, f"the plan module would list {len(target.states)} states of "
                            f"{comps} components, beyond what the Alloy Analyzer verifies in reasonable time "
                            f"({MODULE_BUDGET:,} state-components)")
        try:
            reason, spent, text = _judge(plan, target, solver)
        except AlloyError as err:
            if "capacity exceeded" not in str(err):
                raise
            return _not_run(plan, solver, seconds, f"the plan module of {len(target.states)} states of {comps} "
                            "components has more atoms than the Alloy Analyzer can index")
        seconds += spent
        texts.append(text)
        tried.append("lean" if lean else "full" if lean is not None else "whole")
        if not reason:
            break
    judged = {c.name for c in target.system.components + target.system.versions} if target is not plan else set()
    outside = set(plan.states[0].components) - affected(plan, frozenset(target.stable)) \
        if target is not plan else set()
    if not reason and outside:
        first = alloy_verdict(plan.system, plan.states[0], solver, only=outside)
        seconds += first.seconds
        texts += list(first.texts)
        if not first.valid:
            reason = "the initial configuration is not valid"
    used = getattr(AlloyBridge.get(), "last_solver", solver)
    evidence = {"engine": "alloy", "valid": not reason, "reason": reason, "states": len(plan.states),
                "transitions": len(plan.steps), "solver": used, "seconds": round(seconds, 3),
                "module_hash": "sha256:" + hashlib.sha256("\n".join(texts).encode("utf-8")).hexdigest()}
    if target is not plan:
        evidence["slice"] = {"components": len(judged), "judged_once": len(outside), "kind": tried[-1],
                             "stable_connectors": len(target.stable)}
    if plan.serving:
        evidence["lossless"] = [f"{proxy} serves {conn}" for conn, proxy in plan.serving]
    return evidence


def _judge(plan: Plan, target: Plan, solver: str) -> tuple[str, float, str]:
    """Alloy's verdict on `target` (the plan or a slice of it): why it is refused ("" when
    it is not), the analyzer's time, and the module."""
    from .alloy import alloy_plan_verdict

    verdict = alloy_plan_verdict(target.system, target.states, solver=solver, serving=target.serving,
                                 stable=target.stable)
    for i, ok in enumerate(verdict.valid):
        if not ok:
            return ("the initial configuration is not valid" if i == 0 else
                    f"the state after step {i} ({plan.steps[i - 1].describe()}) is not valid"), \
                verdict.seconds, verdict.text
    for i, (action, did) in enumerate(zip(plan.steps, verdict.steps), 1):
        if action.kind not in did:
            return (f"step {i} ({action.describe()}) is not an instance of {action.kind}: "
                    + ("its preconditions fail" if not did else f"Alloy sees {', '.join(did)}")), \
                verdict.seconds, verdict.text
    for i, ok in enumerate(verdict.lossless):
        if not ok:
            where = "in the initial configuration" if i == 0 else f"after step {i} ({plan.steps[i - 1].describe()})"
            return (f"a client request could be lost {where}: a proxy is not serving (degraded or absent) "
                    "or its clients' connector is unsatisfied"), verdict.seconds, verdict.text
    for i, ok in enumerate(verdict.stable):
        if not ok:
            return (f"a connector the slice relies on is unsatisfied in state {i}"), verdict.seconds, verdict.text
    return "", verdict.seconds, verdict.text
