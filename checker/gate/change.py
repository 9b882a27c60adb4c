"""The gate's judgement of a change from OLD to NEW (`reconf gate`, docs/gate.md).

It passes when NEW is safe and a verified migration plan from OLD to NEW exists within the
policy (`checker.gate.policy`): disruption at most max-disruption, no never-degrade functionality
degraded at any step, no fault covered in OLD left uncovered by NEW's FTMs (keep-ftm).
When OLD itself is not safe no plan from it exists: the gate fails (RC509) and says how to let
a fix through; with `--allow-unsafe-base` (or `allow-unsafe-base = true`) a safe NEW passes
alone, with a warning (RC510) that it must be deployed by other means."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Optional

from checker.alloy import AlloyError, AlloyUnavailable
from checker.alloy.engines import Engine, EngineUnavailable
from checker.ftm.plan_change import plan_change, planned_on
from checker.gate.check import check_system
from checker.gate.policy import Policy, coverage, covered, ftm_names
from checker.planning import NoSafePlan, Plan
from checker.planning.alloy_verify import alloy_evidence
from checker.planning.plan import degraded_runs
from checker.planning.verified import plan_verified
from checker.reports import formats
from checker.reports.plan_document import plan_document
from checker.reports.progress import status
from checker.semantic_model.actions import failing_assumptions
from checker.semantic_model.config import Configuration
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Related, Severity, error, warning
from reconf_dsl.ir import System
from reconf_dsl.span import Span
from reconf_dsl.words import agree, plural


@dataclass
class Outcome:
    diagnostics: list[Diagnostic] = field(default_factory=list)
    cases: list[formats.CheckCase] = field(default_factory=list)
    plan: Any = None
    plan_doc: Optional[dict[str, Any]] = None
    safe: Optional[bool] = None
    base_safe: Optional[bool] = None
    engines: dict[str, Any] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)

    @property
    def nothing_to_do(self) -> bool:
        """A pass whose plan has no step: NEW is what is deployed."""
        return self.passed and self.plan is not None and not self.plan.steps

    def fail(self, suite: str, name: str, d: Diagnostic) -> None:
        self.diagnostics.append(d)
        self.cases.append(formats.CheckCase(suite, name, d.message, "\n".join(d.notes), d.span))

    def ok(self, suite: str, name: str, span: Optional[Span] = None) -> None:
        self.cases.append(formats.CheckCase(suite, name, None, "", span))


def ftm_findings(old: System, new: System, policy: Policy, out: Outcome) -> None:
    """keep-ftm: a fault covered in OLD must stay covered by the same component's FTM in NEW."""
    news = {c.name: c for c in new.components}
    for c in old.components:
        before = covered(c)
        if not before or not policy.protects_ftm(c.name, ftm_names(c.ftm.expr if c.ftm else None)):
            continue
        n = news.get(c.name)
        if n is None:
            continue
        lost = sorted(before - coverage(n.ftm.expr if n.ftm else None))
        name = f"the FTM of {c.name} still covers {', '.join(sorted(before))}"
        if not lost:
            out.ok("gate.policy", name, n.span)
            continue
        was = str(c.ftm.expr) if c.ftm else "none"
        now = str(n.ftm.expr) if n.ftm else "no FTM"
        out.fail("gate.policy", name, error(
            "RC504", f"{c.name}: {', '.join(lost)} {agree(len(lost), 'fault', 'faults')} no longer covered "
            f"({was} → {now}); keep-ftm in {policy.where} forbids weakening it",
            n.ftm.span if n.ftm else n.span,
            related=(Related(c.ftm.span if c.ftm else c.span, f"covered by {was} in the base"),
                     Related(policy.span("keep-ftm"), "keep-ftm")),
            notes=("coverage: PBR, LFR → crash; TR → transient; AD → crash, transient; SEC → intrusion",)))


def degraded_steps(plan: Any) -> dict[tuple[str, str], list[int]]:
    """(component as NEW names it, functionality) → the steps after which it is degraded."""
    return {(plan.renames.get(c, c), f): [i for r in runs for i in r]
            for (c, f), runs in sorted(degraded_runs(plan).items())}


def func_span(systems: list[System], component: str, functionality: str) -> Optional[Span]:
    for s in systems:
        c = s.component(component)
        if c is not None:
            for f in c.functionalities:
                if f.name == functionality:
                    return f.span
    return None


def plan_findings(old: System, new: System, policy: Policy, use_alloy: bool, out: Outcome) -> None:
    with status(f"planning the migration {old.name} → {new.name}…"):
        try:
            verified = plan_verified(lambda fb: plan_change(old, new, policy.strategy, fb), use_alloy=use_alloy,
                                     chain=True, judge=verified_in_alloy)
        except NoSafePlan as e:
            out.fail("gate.policy", "a verified migration plan exists", error(
                "RC501", f"no safe migration plan from the base to {new.name} ({policy.strategy} strategy and "
                "those after it)", new.span, notes=tuple(e.reasons)))
            return
    if verified.not_run is not None:     # not answered: exit 2, as `plan` does
        raise DiagnosticError([error("RC303", f"Alloy could not verify the migration plan: {verified.not_run}",
                                     new.span, notes=("`--engine python` relies on the Python engine's step-by-step "
                                                      "verification alone",))])
    if verified.refuted is not None:
        out.fail("gate.policy", "a verified migration plan exists", error(
            "RC501", f"no verified migration plan from the base to {new.name}: {verified.refuted}", new.span))
        return
    p, evidence = verified.plan, verified.evidence
    out.plan = p
    deployed, target = planned_on(old, new)
    out.plan_doc = plan_document("migrate", deployed, p, evidence, target)
    out.ok("gate.policy", "a verified migration plan exists", new.span)
    if policy.max_disruption is not None:
        name = f"disruption at most {policy.max_disruption}"
        if p.disruption > policy.max_disruption:
            out.fail("gate.policy", name, error(
                "RC502", f"the migration plan's disruption is {p.disruption}, over max-disruption = "
                f"{policy.max_disruption} of {policy.where}", new.span,
                related=(Related(policy.span("max-disruption"), f"max-disruption = {policy.max_disruption}"),),
                notes=(f"plan: {p.summary()}", "disruption = Σ criticality × steps degraded")))
        else:
            out.ok("gate.policy", name, policy.span("max-disruption"))
    if policy.max_degraded_seconds is not None:
        _judge_seconds(out, p, policy, new)
    degraded = degraded_steps(p)
    for i, entry in enumerate(policy.never_degrade):
        hits = sorted((k, v) for k, v in degraded.items() if policy.forbids_degrading(*k) == entry)
        name = f"never degrade {entry}"
        if not hits:
            out.ok("gate.policy", name, policy.entry_span("never-degrade", i))
            continue
        for (c, f), steps in hits:
            span = func_span([new, old], c, f) or new.span
            out.fail("gate.policy", f"{name} ({c}.{f})", error(
                "RC503", f"the migration plan degrades {c}.{f} during {plural(len(steps), 'step')} "
                f"({', '.join(map(str, steps))}); never-degrade in {policy.where} forbids it", span,
                related=(Related(policy.entry_span("never-degrade", i), f"never-degrade includes {entry!r}"),),
                notes=(f"plan: {p.summary()}",)))


def _judge_seconds(out: Outcome, p: Plan, policy: Policy, new: System) -> None:
    """The plan's expected degraded seconds (Σ criticality × seconds, docs/soundness.md#seconds-on-the-wire)
    against the policy's `max-degraded-seconds`."""
    limit, sec = policy.max_degraded_seconds, p.seconds()
    name = f"degraded seconds at most {limit:g}"
    if sec.weighted <= (limit or 0.0):
        out.ok("gate.policy", name, policy.span("max-degraded-seconds"))
        return
    out.fail("gate.policy", name, error(
        "RC512", f"the migration plan is expected to keep what served degraded for {sec.weighted:.2f} s "
        f"(Σ criticality × seconds), over max-degraded-seconds = {limit:g} of {policy.where}", new.span,
        related=(Related(policy.span("max-degraded-seconds"), f"max-degraded-seconds = {limit:g}"),),
        notes=(f"plan: {p.summary()}", f"longest: {sec.longest()}",
               f"durations: {', '.join(p.durations().sources)}")))


def verified_in_alloy(p: Any) -> dict[str, Any]:
    """Alloy's evidence for plan `p` (`checker.planning.alloy_verify.alloy_evidence`), with Alloy
    missing or refusing the module reported as the gate's engine diagnostics (RC301, RC302)."""
    try:
        return alloy_evidence(p)
    except AlloyUnavailable as e:
        raise EngineUnavailable(error("RC301", str(e), Span.unknown("<alloy>"),
                                      notes=("or use --engine python",))) from None
    except AlloyError as e:
        raise EngineUnavailable(error("RC302", f"Alloy rejected the generated plan module: {e}",
                                      Span.unknown(e.module or "<alloy>"),
                                      notes=("this is a bug in reconf: please report it",))) from None


UNSAFE_BASE_CASE = "the base is safe, so a migration from it can be planned"


def unsafe_base_findings(old: System, new: System, failing: list[tuple[str, str, Any]], allowed: Optional[str],
                         out: Outcome) -> None:
    """OLD is not safe, NEW is: no plan from the deployed configuration exists. `allowed` says
    what lets a fix through (the flag or the policy key), None when nothing does."""
    shown = [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in failing]
    reasons = shown[:10] + ([f"… and {len(shown) - 10} more"] if len(shown) > 10 else [])
    related = tuple(Related(s, f"in the base, {c}.{f} assumes {a}, which does not hold")
                    for c, f, a in failing[:10] if (s := func_span([old], c, f)) is not None)
    deploy = ("deployed by other means (a restart, a maintenance window), as no safe step-by-step plan from "
              "the deployed configuration exists")
    if allowed is None:
        out.fail("gate.policy", UNSAFE_BASE_CASE, error(
            "RC509", f"the base {old.name} is not safe ({plural(len(failing), 'assumption')} "
            f"{agree(len(failing), 'does', 'do')} not hold), so no safe migration from the deployed "
            f"configuration exists; {new.name} is safe", old.span, related=related,
            notes=(*reasons, "if this change fixes the base, let it through with --allow-unsafe-base or "
                   "allow-unsafe-base = true in the policy: the gate then judges the head alone, and the change "
                   "must be " + deploy)))
        return
    out.diagnostics.append(warning(
        "RC510", f"the base {old.name} is not safe ({plural(len(failing), 'assumption')} "
        f"{agree(len(failing), 'does', 'do')} not hold): {new.name} was judged alone and is safe; "
        f"{allowed} lets it through, but no safe plan from the deployed configuration exists: deploy it by "
        "other means", old.span, related=related,
        notes=(*reasons, "the change must be " + deploy,
               "max-disruption and never-degrade were not checked: they judge a plan")))
    out.ok("gate.policy", f"{new.name} is safe alone (the base is not; {allowed})", new.span)


def judge_change(old: System, new: System, policy: Policy, engine: Engine,
                 allow_unsafe_base: bool = False, allow_invalid_ftm: bool = False) -> Outcome:
    """The gate's judgement of the change from `old` to `new`. The head is judged as `reconf
    check` judges it: an FTM the FTM rules rule out makes it unsafe, unless `allow_invalid_ftm`
    (those findings are then warnings)."""
    out = Outcome()
    ftm_findings(old, new, policy, out)
    with status(f"checking {new.name}{engine.says()}…"):
        head = check_system(new, engine)        # the head is judged as `reconf check` judges it
    if allow_invalid_ftm:
        head.ftm = [replace(d, severity=Severity.WARNING, notes=d.notes + ("allowed by --allow-invalid-ftm",))
                    if d.is_error and d.code != "RC401" else d for d in head.ftm]
    broken = [d for d in head.ftm if d.is_error]
    out.safe, out.engines = head.safe, head.engines
    out.cases[:0] = head.cases()
    out.diagnostics[:0] = head.diagnostics
    base_failing = failing_assumptions(old, Configuration.initial(old))
    out.base_safe = not base_failing
    if not out.safe:
        failing = len(head.judged.python.unsatisfied)
        notes: tuple[str, ...] = ((f"{plural(failing, 'assumption')} {agree(failing, 'does', 'do')} not "
                                   f"hold; see above",) if failing else ())
        notes += ((f"{plural(len(broken), 'fault-tolerance rule')} {agree(len(broken), 'is', 'are')} "
                   f"broken; see above",) if broken else ())
        d = error("RC507", f"{new.name} is not safe: no migration to it is planned", new.span,
                  notes=notes + ((f"the base {old.name} is not safe either",) if base_failing else ()))
        out.fail("gate.policy", "a verified migration plan exists", d)
        return out
    if base_failing:
        allowed = ("--allow-unsafe-base" if allow_unsafe_base else
                   f"allow-unsafe-base = true in {policy.where}" if policy.allow_unsafe_base else None)
        unsafe_base_findings(old, new, base_failing, allowed, out)
        return out
    plan_findings(old, new, policy, engine.alloy, out)
    return out
