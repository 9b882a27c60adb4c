"""A plan from anywhere, verified by both engines on their own (`reconf plan verify`).

The Python engine judges the plan state by state and step by step with the rules of
`checker.semantic_model.rules` (each configuration well formed and valid; each step's preconditions in
the configuration before it, and the configuration after it its effect) and names the first
rule broken, at the step or the configuration of the document that breaks it. Alloy judges
the same plan as it judges the plans reconf makes (`checker.planning.alloy_verify`: every
configuration valid and well formed, every step an instance of its action's predicate), in
windows on the part of the architecture each can affect. The two must agree; a disagreement
is a bug in reconf (RC300).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from checker.alloy.engines import Engine
from checker.planning.alloy_verify import alloy_batches, alloy_evidence
from checker.planning.batches import batch_refusal
from checker.planning.plan import Goal, Plan
from checker.reports.plan_reader import PlanInput
from checker.semantic_model.actions import state_refusals, step_refusals
from checker.semantic_model.config import Configuration
from checker.semantic_model.rules import Refusal
from reconf_dsl.diagnostics import Diagnostic, error
from reconf_dsl.ir import System
from reconf_dsl.span import Span

__all__ = ["PlanJudgement", "verify_plan", "CODES"]

# The code of each kind of broken rule (reconf_dsl/codes.py).
CODES = {"step": "RC304", "effect": "RC305", "formed": "RC306", "valid": "RC307", "batch": "RC310"}


@dataclass
class PlanJudgement:
    """Each engine's verdict on a plan: `python` (the first rule broken, as a diagnostic, or
    None) and `alloy` (its evidence, as plan documents carry it), and the seconds each took."""

    plan: PlanInput
    engines: dict[str, dict[str, Any]] = field(default_factory=dict)
    diagnostics: list[Diagnostic] = field(default_factory=list)

    @property
    def safe(self) -> bool:
        return all(e["valid"] for e in self.engines.values())


def _code(r: Refusal) -> str:
    if r.rule == "state.valid":
        return CODES["valid"]
    if r.rule.startswith("state."):
        return CODES["formed"]
    return CODES["effect"] if r.rule.endswith(".effect") else CODES["step"]


def first_broken(system: System, plan: PlanInput) -> Optional[Diagnostic]:
    """The Python engine's judgement: the first rule the plan breaks, where it breaks it, or None."""
    where = _where(plan)
    found = _state(system, plan.states[0], plan.state_spans[0], where(0))
    if found:
        return found
    for i, action in enumerate(plan.steps):
        before, after = plan.states[i], plan.states[i + 1]
        refused = step_refusals(system, before, action, after)
        if refused:
            r = refused[0]
            return error(_code(r), f"step {i + 1} ({action.describe()}) breaks {r.rule}: {r.text}",
                         plan.step_spans[i], notes=_more(refused))
        found = _state(system, after, plan.state_spans[i + 1], where(i + 1))
        if found:
            return found
    return None


def _where(plan: PlanInput) -> Callable[[int], str]:
    """How the diagnostics name configuration i of the plan."""
    def name(i: int) -> str:
        return "the first configuration" if i == 0 else f"the configuration after step {i} ({plan.steps[i - 1].describe()})"
    return name


def _state(system: System, config: Configuration, span: Span, name: str) -> Optional[Diagnostic]:
    """The first rule configuration `config` (named `name`, given at `span`) breaks, or None."""
    refused = state_refusals(system, config)
    if not refused:
        return None
    r = refused[0]
    return error(_code(r), f"{name} breaks {r.rule}: {r.text}", span, notes=_more(refused))


def _more(refused: list[Refusal]) -> tuple[str, ...]:
    return tuple(f"also {r.rule}: {r.text}" for r in refused[1:5])


def verify_plan(system: System, plan: PlanInput, engine: Engine = Engine.BOTH) -> PlanJudgement:
    """Judge `plan` on `system` with the engines `engine` names."""
    out, as_plan = PlanJudgement(plan), _as_plan(system, plan)
    if engine.python:
        clock = time.perf_counter()
        found = first_broken(system, plan) or _unsafe_batch(as_plan, plan)
        out.engines["python"] = {"engine": "python", "valid": found is None, "states": len(plan.states),
                                 "reason": found.message if found else "", "seconds": round(time.perf_counter() - clock, 3)}
        if found is not None:
            out.diagnostics.append(found)
    if engine.alloy:
        out.engines["alloy"] = alloy = alloy_evidence(as_plan, given=True)
        if plan.batches and alloy.get("valid"):
            alloy["batches"] = judged = alloy_batches(as_plan, plan.batches)
            if judged["refused"]:
                which, why = next(iter(judged["refused"].items()))
                alloy.update(valid=False, reason=f"the batch of steps {which}: {why}")
    return out


def _unsafe_batch(as_plan: Plan, plan: PlanInput) -> Optional[Diagnostic]:
    """The first batch of the document (`as_plan`: its plan) that is unsafe in some order
    (checker.planning.batches), or None."""
    for (first, last), span in zip(plan.batches, plan.batch_spans):
        why = batch_refusal(as_plan, first, last)
        if why:
            return error(CODES["batch"], f"steps {first}–{last}, run together, are unsafe: {why}", span)
    return None


def _as_plan(system: System, plan: PlanInput) -> Plan:
    """The document's plan as the planners' plans are, for Alloy's verification of plans."""
    last = plan.states[-1]
    return Plan(system, list(plan.steps), list(plan.states), "document", 0,
                Goal(last.components, last.roles, last.degraded))
