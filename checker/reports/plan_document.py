"""The plan document: what `reconf plan --output-format json` prints, what the gate reports as its
plan, and, with the model added, what a plan script embeds (`-o plan.py`, the golden scripts).
One builder for all of them; its fields are described in docs/executor.md."""
from __future__ import annotations

import hashlib
from dataclasses import replace
from typing import Any, Optional

from checker.planning import Plan
from checker.planning.plan import degradation
from codegen.ros2 import FORMAT_VERSION, model_data
from reconf_dsl.ir import System


def fingerprint(system: System) -> str:
    """A digest of what the architecture says (not where it was written, nor its layout)."""
    return "sha256:" + hashlib.sha256(repr(replace(system, files=())).encode("utf-8")).hexdigest()


def plan_document(label: str, system: System, p: Plan, evidence: dict[str, Any],
                  target: Optional[System] = None, *, model: bool = False) -> dict[str, Any]:
    """The document of plan `p` for `label` (`replace talker`, `migrate a.arch → b.arch`) on
    `system`, with the `evidence` its verification established; with `model`, the plan's system
    as the executor reads it (a plan script's document)."""
    doc: dict[str, Any] = {"format_version": FORMAT_VERSION, "tool": "reconf", "command": "plan",
                           "operation": label, "verdict": "plan", "system": system.name,
                           "fingerprint": fingerprint(system), "plan": p.to_dict(),
                           "degradation": degradation(p), "evidence": evidence}
    if target is not None:
        doc["target_fingerprint"] = fingerprint(target)
    return with_model(doc, p) if model else doc


def with_model(doc: dict[str, Any], p: Plan) -> dict[str, Any]:
    """A plan document as a plan script embeds it: with the plan's system as the executor reads it."""
    return dict(doc, model=model_data(p.system))
