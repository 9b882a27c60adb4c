"""Recovery: plan from an observed configuration (a failed run's report, or the live system)
to a target, whatever the observed configuration is (docs/executor.md#failure-and-recovery).

An observed configuration may not be valid (a node died, an operator changed a mode). The plan
then first restores validity by degrading, and only degrading: the functionalities whose
assumptions fail, then those that this degrading leaves failing, until nothing fails
(`restore_validity`). That set is the least one that makes the configuration valid with its
components and attachments as they are, and whatever the order of its degrades, every state
on the way fails only on functionalities a later one of them degrades: both follow from
`RecoverMonotone` and `RecoverDegrade`, proved for every size with z3 and in the meta-model
(docs/soundness.md#restoring-validity). `check_restore` checks that property on the prefix
itself; from the prefix's end the plan is an ordinary one, verified step by step by the
Python engine and as a whole by Alloy (`Recovery.rest`).
"""
from __future__ import annotations

from dataclasses import replace as dc_replace
from typing import Any, Callable, Iterable, Optional

from checker.planning.chain import Fallback, plan_with_fallback
from checker.planning.plan import Goal, NoSafePlan, Plan, Problem, Recovery, disruption
from checker.planning.states import States
from checker.planning.strategies import solve
from checker.semantic_model.actions import Degrade, catalogue, effect, failing_assumptions
from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.ir import System
from reconf_dsl.words import plural

__all__ = ["plan_recovery", "restore_validity", "check_restore"]


def _failing(system: System, config: Configuration) -> set[FuncId]:
    return {(c, f) for c, f, _ in failing_assumptions(system, config)}


def restore_validity(system: System, observed: Configuration) -> list[Degrade]:
    """The degrades that make `observed` valid, changing nothing else: the functionalities whose
    assumptions fail (layer 0), then those that fail once layer 0 is degraded (layer 1), and so
    on until nothing fails; the least such set (docs/soundness.md#restoring-validity).

    They are ordered readers first (the last layer first): a functionality is degraded before
    what it reads is, so on the wire no reader still relying on its input sees that input fall
    silent under it. Any order would be sound: every state fails only on functionalities a later
    step degrades (`RecoverMonotone`)."""
    layers: list[list[FuncId]] = []
    degraded = set(observed.degraded)
    while True:
        new = sorted(_failing(system, dc_replace(observed, degraded=frozenset(degraded))) - degraded)
        if not new:
            break
        layers.append(new)
        degraded |= set(new)
    return [Degrade(c, f) for layer in reversed(layers) for c, f in layer]


def check_restore(system: System, observed: Configuration, prefix: Iterable[Degrade]) -> Configuration:
    """The prefix's end, after checking the property the proofs establish for it: each step
    degrades a present functionality in its normal mode, every state before the end fails only
    on functionalities a later step of the prefix degrades, and the end is valid. Raises
    NoSafePlan, saying which step or state breaks it."""
    steps = list(prefix)
    funcs = catalogue(system).funcs
    later = {(a.component, a.functionality) for a in steps}
    state = observed
    for i, a in enumerate(steps, 1):
        fid = (a.component, a.functionality)
        outside = sorted(_failing(system, state) - later)
        if outside:
            c, f = outside[0]
            raise NoSafePlan([f"restoring validity: before step {i}, {c}.{f} fails and no later step degrades it"])
        if not isinstance(a, Degrade) or fid not in funcs or a.component not in state.components \
                or fid in state.degraded:
            raise NoSafePlan([f"restoring validity: step {i} ({a.describe()}) is not a degrade of a present "
                              "functionality in its normal mode"])
        later.discard(fid)
        state = effect(system, state, a)
    left = sorted(_failing(system, state))
    if left:
        c, f = left[0]
        raise NoSafePlan([f"restoring validity: after {plural(len(steps), 'degrade')}, {c}.{f} still fails"])
    return state


def _planned_on(system: System, start: Configuration) -> System:
    """`system` with the components present in `start` as its deployed ones, the others as
    versions (what a plan may create)."""
    every = system.components + system.versions
    return dc_replace(system, components=tuple(c for c in every if c.name in start.components),
                      versions=tuple(c for c in every if c.name not in start.components))


def plan_recovery(system: System, observed: Configuration, target: Configuration, strategy: str = "default",
                  fallback: Optional[Fallback] = None, placed: Optional[dict[str, str]] = None,
                  orphans: Iterable[dict[str, Any]] = (), renames: Optional[dict[str, str]] = None,
                  reorder: Optional[Callable[[Plan], Plan]] = None) -> Plan:
    """A plan from `observed` to `target`: the degrades that restore validity, then a plan made
    by `strategy` (through the fallback chain when `fallback` is given) from there. The plan's
    `recovery` says how many steps restore validity, and carries `placed` and `orphans` for the
    executor (`Recovery`); `renames`, the new versions the target has of components that run
    (`X@new` -> X), for the executor's names; `reorder`, a verified reordering of the plan from
    there (an FTM's watchers resumed last, checker.ftm.resume). Raises NoSafePlan when no plan
    reaches the target."""
    prefix = restore_validity(system, observed)
    start = check_restore(system, observed, prefix)
    base = _planned_on(system, start)
    problem = Problem(base, start, Goal(target.components, target.roles, target.degraded), renames=dict(renames or {}))
    if fallback is not None:
        rest = plan_with_fallback(problem, strategy, dc_replace(fallback, shape=reorder) if reorder else fallback)
    else:
        rest = solve(problem, strategy) if reorder is None else reorder(solve(problem, strategy))
    info = Recovery(len(prefix), rest, dict(placed or {}), list(orphans))
    if not prefix:
        rest.recovery = info
        return rest
    base = _planned_on(system, observed)
    steps = list(prefix) + rest.steps
    states = States(base, observed, steps)
    first = "step 1 degrades" if len(prefix) == 1 else f"steps 1-{len(prefix)} degrade"
    notes = [f"the observed configuration is not valid: {first} what fails in it, and what that leaves "
             "failing (docs/soundness.md#restoring-validity)"] + rest.notes
    return Plan(base, steps, states, rest.strategy, disruption(base, states, steps), rest.goal, dict(rest.renames),
                notes, rest.verification, attempts=list(rest.attempts), recovery=info)
