"""A plan made and verified, the one path to a plan that `reconf plan`, `up`, `down`, `recover`,
`plan transition` and the gate show: made by a strategy alone or through the fallback chain
(`checker.planning.chain`, where a plan Alloy refutes hands over to the next strategy), checked
step by step by the Python engine as it is made, and as a whole in Alloy (`alloy_verify`)."""
from __future__ import annotations

from dataclasses import dataclass
from dataclasses import replace as dc_replace
from typing import Any, Callable, Optional

from checker.planning.alloy_search import plan_with_alloy
from checker.planning.alloy_verify import PlanVerdicts, alloy_batches, alloy_evidence
from checker.planning.batches import batch_plan, parallel_note
from checker.planning.chain import Fallback
from checker.planning.plan import Plan, Problem, verify
from reconf_dsl.words import plural


@dataclass
class Verified:
    plan: Plan
    evidence: dict[str, Any]     # per engine, as the plan document carries it

    @property
    def not_run(self) -> Optional[str]:
        """Why Alloy could not verify the plan (a question not answered: RC303), or None."""
        alloy = self.evidence.get("alloy")
        return str(alloy.get("reason", "unknown")) if alloy and alloy.get("verdict") == "not run" else None

    @property
    def refuted(self) -> Optional[str]:
        """Alloy's refutation of the plan, or None."""
        alloy = self.evidence.get("alloy")
        if not alloy or self.not_run is not None or alloy.get("valid", False):
            return None
        return f"Alloy refuted the plan: {alloy.get('reason', 'unknown')}"


def plan_verified(make: Callable[..., Plan], *, use_alloy: bool, chain: bool,
                  judge: Callable[[Plan], dict[str, Any]] = alloy_evidence, alloy_planner: bool = False,
                  max_steps: int = 12, progress: Optional[Callable[[str], None]] = None) -> Verified:
    """The plan `make` makes, with its evidence. With `chain`, `make` takes the `Fallback` to
    plan through; otherwise `make()` plans alone. `judge` gives Alloy's evidence on a plan
    (unless not `use_alloy`); with `alloy_planner`, Alloy 6 plans the same change again.
    Raises NoSafePlan (NoPlanFound through the chain)."""
    verdicts = PlanVerdicts(judge) if use_alloy else None
    if chain:
        p = make(Fallback(accept=verdicts.refused if verdicts else None, alloy=use_alloy or alloy_planner,
                          max_steps=max_steps, progress=progress))
    else:
        p = make()
    if alloy_planner:
        p = alloy_planned(p, max_steps)
    p = _batched(p)
    evidence: dict[str, Any] = {"python": {"engine": "python", "states": len(p.states), "valid": True}}
    if p.batches:
        evidence["python"]["batches"] = len(p.batches)
    rest = p
    if p.recovery is not None and p.recovery.restore and p.recovery.rest is not None:
        # a recovery's first steps restore validity: judged by the proved property
        # (checker.planning.recovery.check_restore); Alloy verifies the plan from their end
        evidence["python"]["restore"] = {"steps": p.recovery.restore, "valid_from": p.recovery.restore,
                                         "proved": ["RecoverDegrade", "RecoverMonotone"]}
        rest = p.recovery.rest
    if verdicts is not None:
        evidence["alloy"] = verdicts.evidence(rest)
        if p.batches and evidence["alloy"].get("valid"):
            evidence["alloy"] = dict(evidence["alloy"], batches=_alloy_batches(p))
    if p.batches:
        p.notes.append(parallel_note(p.batches))
    return Verified(p, evidence)


def _batched(p: Plan) -> Plan:
    """`p` with its steps grouped into batches the Python engine proves (checker.planning.batches),
    re-linking steps moved to run together where the plan stays valid: then verified again in its
    new order, as any plan. Not the paper strategy's, which stays Algorithm 1 as the baseline;
    a recovery's steps are grouped as they are, after those that restore validity."""
    if p.strategy == "paper" or not p.steps:
        return p
    restore = p.recovery.restore if p.recovery is not None else None
    steps, batches = batch_plan(p, 1 if restore is None else restore + 1, move=restore is None)
    if steps != p.steps:
        again = verify(p.system, p.states[0], steps, p.goal, p.strategy, p.renames)
        moved = sum(a is not b for a, b in zip(steps, p.steps))
        p = dc_replace(p, steps=steps, states=again.states, disruption=again.disruption,
                       notes=p.notes + [f"{moved} re-linking steps moved to run with the batch before them; "
                                        "the plan verified again in its new order"])
    p.batches = batches
    return p


def _alloy_batches(p: Plan) -> dict[str, Any]:
    """Alloy's judgement of `p`'s batches; a batch it refuses runs one step at a time, with a
    warning (the engines disagree: a bug in reconf)."""
    judged = alloy_batches(p, p.batches)
    if judged["refused"]:
        p.batches = [b for b in p.batches if f"{b[0]}-{b[1]}" not in judged["refused"]]
        p.notes += [
            f"warning: Alloy refused the batch of steps {k}, which the Python engine allowed ({why}); its steps run one "
            "at a time; please report it" for k, why in judged["refused"].items()]
    return judged


def alloy_planned(p: Plan, max_steps: int) -> Plan:
    """The same change planned by Alloy 6: the problem (start, settled goal) is the Python plan's."""
    planned = plan_with_alloy(Problem(p.system, p.states[0], p.goal, renames=dict(p.renames)), max_steps)
    planned.notes.append(f"the Python {p.strategy} strategy's plan had disruption {p.disruption} "
                         f"in {plural(len(p.steps), 'step')}")
    return planned
