"""The Alloy half of a plan's verification: every state valid, every step an instance of the
action the plan says it is, with that action's preconditions (the meta-model's predicates)."""
from __future__ import annotations

import hashlib
from typing import Any

from .planning import Plan


def alloy_evidence(plan: Plan, solver: str = "glucose") -> dict[str, Any]:
    """Evidence for the plan document; `valid` is False (with a `reason`) when Alloy refutes it.

    Raises the bridge's AlloyUnavailable when Java or the jar is missing."""
    from .alloy import alloy_plan_verdict
    from .alloy.bridge import AlloyBridge

    verdict = alloy_plan_verdict(plan.system, plan.states, solver=solver)
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
    used = getattr(AlloyBridge.get(), "last_solver", solver)
    return {"engine": "alloy", "valid": not reason, "reason": reason, "states": len(plan.states),
            "transitions": len(plan.steps), "solver": used, "seconds": round(verdict.seconds, 3),
            "module_hash": "sha256:" + hashlib.sha256(verdict.text.encode("utf-8")).hexdigest()}
