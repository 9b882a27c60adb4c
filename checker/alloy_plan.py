"""The Alloy half of a plan's verification: every state valid, every step an instance of the
action the plan says it is, with that action's preconditions (the meta-model's predicates)."""
from __future__ import annotations

import hashlib
from typing import Any

from .planning import Plan


def alloy_evidence(plan: Plan, solver: str = "glucose", slice_: bool = True) -> dict[str, Any]:
    """Evidence for the plan document; `valid` is False (with a `reason`) when Alloy refutes it.

    With `slice_` (the default), the plan module holds only the part of the architecture the
    plan can affect (`checker.planning.slicing`); the assumptions of every other component
    read nothing the plan changes, and Alloy judges them once, in the first configuration.
    A plan that must keep proxies serving (`Plan.serving`) is also checked lossless in every
    state. Raises the bridge's AlloyUnavailable when Java or the jar is missing."""
    from .alloy import alloy_plan_verdict, alloy_verdict
    from .alloy.bridge import AlloyBridge
    from .planning.slicing import affected, slice_plan

    target, outside = plan, set()
    if slice_ and plan.states:
        outside = set(plan.states[0].components) - affected(plan)
        if outside:
            target = slice_plan(plan)
    verdict = alloy_plan_verdict(target.system, target.states, solver=solver, serving=target.serving)
    seconds = verdict.seconds
    reason = ""
    for i, ok in enumerate(verdict.valid):
        if not ok:
            reason = "the initial configuration is not valid" if i == 0 else \
                f"the state after step {i} ({plan.steps[i - 1].describe()}) is not valid"
            break
    if not reason:
        for i, (action, did) in enumerate(zip(plan.steps, verdict.steps), 1):
            if action.kind not in did:
                reason = f"step {i} ({action.describe()}) is not an instance of {action.kind}: " + \
                    ("its preconditions fail" if not did else f"Alloy sees {', '.join(did)}")
                break
    if not reason:
        for i, ok in enumerate(verdict.lossless):
            if not ok:
                where = "in the initial configuration" if i == 0 else \
                    f"after step {i} ({plan.steps[i - 1].describe()})"
                reason = f"a client request could be lost {where}: a proxy is not serving " \
                    "(degraded or absent) or its clients' connector is unsatisfied"
                break
    texts = [verdict.text]
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
        evidence["slice"] = {"components": len(target.system.components) + len(target.system.versions),
                             "judged_once": len(outside)}
    if plan.serving:
        evidence["lossless"] = [f"{proxy} serves {conn}" for conn, proxy in plan.serving]
    return evidence
