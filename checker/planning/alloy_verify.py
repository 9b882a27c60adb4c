"""The Alloy half of a plan's verification: every state valid, every step an instance of the
action the plan says it is, with that action's preconditions (the meta-model's predicates)."""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from typing import Any, Callable, Optional, Sequence

from checker.alloy import alloy_plan_verdict, alloy_verdict
from checker.alloy.errors import AlloyError
from checker.alloy.instance import AlloyPlanVerdict
from checker.planning import Plan
from checker.planning.batches import moves
from checker.planning.slicing import PlanSlicer, slice_plan
from checker.semantic_model.actions import Action, effect
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import Predicate
from reconf_dsl.words import plural

# states x components of a plan module past which it is not run (about a minute of work here)
MODULE_BUDGET = 40_000
# states x components of one window of a plan (see alloy_evidence): the analyzer's time grows
# with states x slice, so narrower windows cost less in all, down to where the per-window work
# (slicing, writing and parsing the module) takes over; measured on the DAG plan of bench_alloy
WINDOW_BUDGET = 750
# atoms of one window's instance past which it is split: every relation is binary, and the
# analyzer indexes a binary relation's tuples by universe² < 2³¹ (about 46,000 atoms)
WINDOW_ATOMS = 40_000


def _not_run(plan: Plan, seconds: float, reason: str) -> dict[str, Any]:
    return {"engine": "alloy", "valid": False, "verdict": "not run", "reason": reason, "states": len(plan.states),
            "transitions": len(plan.steps), "method": "evaluation", "seconds": round(seconds, 3)}


class PlanVerdicts:
    """Alloy's evidence on each plan a fallback chain finds (`planning.Fallback.accept`): a plan
    Alloy refutes hands over to the next strategy; one it could not verify is not refuted (the
    caller reports RC303). Each plan is judged once by `judge`, its evidence kept for the plan
    document."""

    def __init__(self, judge: Callable[[Plan], dict[str, Any]]) -> None:
        self._judge = judge
        self._seen: dict[int, tuple[Plan, dict[str, Any]]] = {}

    def evidence(self, plan: Plan) -> dict[str, Any]:
        seen = self._seen.get(id(plan))
        if seen is not None and seen[0] is plan:
            return seen[1]
        found = self._judge(plan)
        self._seen[id(plan)] = (plan, found)
        return found

    def refused(self, plan: Plan) -> Optional[str]:
        found = self.evidence(plan)
        if found.get("verdict") == "not run" or found.get("valid", False):
            return None
        return f"Alloy refuted the plan: {found.get('reason', 'unknown')}"


def alloy_evidence(plan: Plan, slice_: bool = True,
                   progress: Callable[[str], None] | None = None, given: bool = False) -> dict[str, Any]:
    """Evidence for the plan document; `valid` is False (with a `reason`) when Alloy refutes it.

    With `slice_` (the default), the plan is verified in *windows* of consecutive steps, each
    on the part of the architecture it can affect, lean slice first, then the full one if the
    lean is refuted; the components no window judges are judged once, in the first
    configuration. Why that suffices: docs/soundness.md, "Verifying a plan in windows".
    `progress` is told how many windows there are, then which steps each window judged one at
    a time holds. With `given`, the plan's states are given (a plan document), not made by
    its steps: every component that changes between two of them is sliced as acted on.
    Raises the bridge's AlloyUnavailable when Java or the jar is missing."""
    if not slice_ or not plan.steps:
        return _whole(plan)
    tally, slicer = _Tally(), PlanSlicer(plan, given)
    try:
        k, width = _at_once(plan, slicer, tally, progress)
        reason = _one_at_a_time(plan, slicer, tally, k, width, progress)
    except _NotRun as e:
        return _not_run(plan, tally.seconds, str(e))
    outside = set(plan.states[0].components) - tally.judged
    if not reason and outside:
        first = alloy_verdict(plan.system, plan.states[0], only=outside)
        tally.seconds += first.seconds
        tally.texts += list(first.texts)
        if not first.valid:
            reason = "the initial configuration is not valid"
    evidence = _evidence(plan, reason, tally.seconds, tally.texts)
    evidence["slice"] = {"components": tally.largest, "judged_once": len(outside), "windows": len(tally.widths),
                         "kind": "full" if "full" in tally.kinds else "lean"}
    return evidence


class _NotRun(Exception):
    """A module too large to run: the plan is not verified (the reason is the message)."""


@dataclass
class _Tally:
    """What the windows judged so far add up to."""

    seconds: float = 0.0
    texts: list[str] = field(default_factory=list)
    kinds: set[str] = field(default_factory=set)      # "lean", "full": the slices that decided
    widths: list[int] = field(default_factory=list)   # one per window
    largest: int = 0                                  # components of the largest slice judged
    judged: set[str] = field(default_factory=set)     # the components some window's slice judges

    def spent(self, seconds: float, text: str) -> None:
        self.seconds += seconds
        self.texts.append(text)

    def window(self, kind: str, width: int, target: Plan, core: set[str]) -> None:
        self.kinds.add(kind)
        self.widths.append(width)
        self.largest = max(self.largest, _size(target))
        self.judged |= core


def _at_once(plan: Plan, slicer: PlanSlicer, tally: _Tally,
             progress: Callable[[str], None] | None) -> tuple[int, int]:
    """The windows judged at once (by two analyzers where that pays) as long as their lean
    slices are proved: the step and width to go on from one at a time, from the first that
    is not."""
    windows, too_big = _windows(plan, slicer)
    if progress is not None:
        progress(f"verifying {plural(len(plan.steps), 'step')} in {plural(len(windows), 'window')} in the Alloy "
                 "Analyzer…")
    proved = 0
    for (_, width, lean, core), (ok, spent, text) in zip(windows, _judge_at_once(plan, windows)):
        if not ok:
            break
        tally.spent(spent, text)
        tally.window("lean", width, lean, core)
        proved += 1
    if proved < len(windows):
        return windows[proved][0], windows[proved][1]
    if too_big:
        raise _NotRun(too_big)
    return len(plan.steps), len(plan.steps)


def _one_at_a_time(plan: Plan, slicer: PlanSlicer, tally: _Tally, k: int, width: int,
                   progress: Callable[[str], None] | None) -> str:
    """The windows from step `k` on, one at a time: a window is as long as keeps its module
    within `WINDOW_BUDGET` state-components (halved until it does, or until the analyzer can
    index it), and doubles after each proved. The reason Alloy refuted a window, or ""."""
    reason = ""
    while k < len(plan.steps) and not reason:
        width = min(width, len(plan.steps) - k)
        window = _window(plan, k, width)
        lean, lean_core = slicer.slice(window, lean=True)
        if width > 1 and _oversized(lean):
            width = _narrower(width, lean)
            continue
        if _cost(lean) > MODULE_BUDGET:
            raise _NotRun(_too_big(lean))
        if progress is not None:
            progress(f"verifying steps {k + 1}–{k + width} of {len(plan.steps)} in the Alloy Analyzer "
                     f"({_size(lean)} components)…")
        try:
            reason, spent, text = _judge(plan, lean, k)
            target, core = lean, lean_core
            if reason:
                # refuted on the lean slice, maybe only for what it left out: the full slice
                # decides, on narrower windows if it does not fit this one
                tally.spent(spent, text)
                target, core = slicer.slice(window)
                if width > 1 and _oversized(target):
                    width, reason = _narrower(width, target), ""
                    continue
                if _cost(target) > MODULE_BUDGET:
                    raise _NotRun(_too_big(target))
                reason, spent, text = _judge(plan, target, k)
        except AlloyError as err:
            if not _capacity(err):
                raise
            if width == 1:
                raise _NotRun(f"the plan module of step {k + 1} has more atoms than the Alloy Analyzer can "
                              "index, even with binary relations") from None
            width, reason = width // 2, ""
            continue
        tally.spent(spent, text)
        tally.window("lean" if target is lean else "full", width, target, core)
        k += width
        width *= 2
    return reason


def _windows(plan: Plan, slicer: "PlanSlicer") -> tuple[list[tuple[int, int, Plan, set[str]]], str]:
    """The windows `alloy_evidence` judges when every lean slice is proved: (first step,
    steps, lean slice, its core) each, up to the first past `MODULE_BUDGET`, and then why
    the plan cannot be verified ("" when none is)."""
    out: list[tuple[int, int, Plan, set[str]]] = []
    k, width = 0, len(plan.steps)
    while k < len(plan.steps):
        width = min(width, len(plan.steps) - k)
        lean, core = slicer.slice(_window(plan, k, width), lean=True)
        if width > 1 and _oversized(lean):
            width = _narrower(width, lean)
            continue
        if _cost(lean) > MODULE_BUDGET:
            return out, _too_big(lean)
        out.append((k, width, lean, core))
        k += width
        width *= 2
    return out, ""


def _judge_at_once(plan: Plan, windows: list[tuple[int, int, Plan, set[str]]]) -> list[tuple[bool, float, str]]:
    """`plan_safe` of each window's lean slice: per window, whether it is proved, the
    analyzer's seconds and the instance it read. Stops at the first error (the windows are
    then judged one at a time, where each error is reported)."""
    out = []
    for _, _, lean, _ in windows:
        try:
            verdict = _verdict(lean)
        except Exception:  # noqa: BLE001 - judged one at a time below, with the error where it is
            break
        out.append((verdict.ok, verdict.seconds, verdict.text))
    return out


def _whole(plan: Plan) -> dict[str, Any]:
    """The plan judged in one module on its whole architecture."""
    if _cost(plan) > MODULE_BUDGET:
        return _not_run(plan, 0.0, _too_big(plan))
    try:
        reason, seconds, text = _judge(plan, plan)
    except AlloyError as err:
        if not _capacity(err):
            raise
        return _not_run(plan, 0.0, f"the plan module of {len(plan.states)} states of {_size(plan)} "
                        "components has more atoms than the Alloy Analyzer can index")
    return _evidence(plan, reason, seconds, [text])


def _evidence(plan: Plan, reason: str, seconds: float, texts: list[str]) -> dict[str, Any]:
    evidence = {"engine": "alloy", "valid": not reason, "reason": reason, "states": len(plan.states),
                "transitions": len(plan.steps), "method": "evaluation", "seconds": round(seconds, 3),
                "module_hash": "sha256:" + hashlib.sha256("\n".join(texts).encode("utf-8")).hexdigest()}
    if plan.serving or plan.handover:
        evidence["lossless"] = [f"{proxy} serves {conn}" for conn, proxy in plan.serving] + \
            [f"{proxy} serves {conn} while it publishes on it" for conn, proxy in plan.handover]
    return evidence


def _window(plan: Plan, k: int, width: int) -> Plan:
    """Steps k .. k + width - 1 of `plan`, with the states around them."""
    return dc_replace(plan, steps=plan.steps[k:k + width], states=plan.states[k:k + width + 1],
                      stable=[], notes=[])


def _atoms(target: Plan) -> int:
    """About how many atoms the plan module of `target` has (an estimate, to choose window
    sizes; the analyzer's capacity error is the final word): states, components, ports,
    functionalities, connectors, and per datum its message and rate."""
    system = target.system
    count = len(target.states) + len(system.connectors) + 24
    data: set[Optional[Predicate]] = set()
    data |= {k.guarantee for k in system.connectors} | {e.guarantee for e in system.environment}
    for c in system.components + system.versions:
        count += 1 + len(c.ports) + len(c.functionalities)
        data |= {p.assumption for p in c.ports if p.kind == "input"}
        for f in c.functionalities:
            outs = [p for p in f.ports if (q := c.port(p)) is not None and q.kind == "output"]
            data |= {m.guarantee(p) for m in (f.normal, f.degraded) if m is not None for p in outs}
            data |= set(f.normal.assumptions) if f.normal is not None else set()
    return count + 3 * len(data)


def _cost(target: Plan) -> int:
    """A module's size in state-components."""
    return len(target.states) * _size(target)


def _oversized(target: Plan) -> bool:
    """Whether a window's module is past `WINDOW_BUDGET` or too large for ternary relations."""
    return _cost(target) > WINDOW_BUDGET or _atoms(target) > WINDOW_ATOMS


def _narrower(width: int, target: Plan) -> int:
    """A narrower window than `width` steps, about as wide as the budget allows `target`'s slice."""
    return max(1, min(width // 2, WINDOW_BUDGET // (2 * _size(target))))


def _capacity(err: AlloyError) -> bool:
    """Whether the analyzer refused a module for its number of atoms."""
    return "capacity exceeded" in str(err)


def _size(plan: Plan) -> int:
    return len(plan.system.components) + len(plan.system.versions)


def _too_big(target: Plan) -> str:
    # the module lists every state: past this, the analyzer takes minutes or fails
    return (f"the plan module would list {len(target.states)} states of {_size(target)} components, beyond what "
            f"the Alloy Analyzer verifies in reasonable time ({MODULE_BUDGET:,} state-components)")


def _verdict(target: Plan) -> "AlloyPlanVerdict":
    return alloy_plan_verdict(target.system, target.states, serving=target.serving, stable=target.stable,
                              protocols=target.protocols, handover=target.handover, actions=target.steps)


def _judge(plan: Plan, target: Plan, offset: int = 0) -> tuple[str, float, str]:
    """Alloy's verdict on `target` (the plan, or a slice of its steps from `offset` on):
    why it is refused ("" when it is not), the analyzer's time, and the instance it read."""
    verdict = _verdict(target)

    def after(i: int) -> str:
        """State i of the module, in the plan's words."""
        n = offset + i
        return "the initial configuration" if n == 0 else f"the state after step {n} ({plan.steps[n - 1].describe()})"

    for i in range(len(verdict.valid)):
        why = _state_refused(verdict, i, after(i))
        if not why and i < len(verdict.steps):
            n = offset + i + 1
            action, did = plan.steps[n - 1], verdict.steps[i]
            if action.kind not in did:
                why = (f"step {n} ({action.describe()}) is not an instance of {action.kind}: "
                       + ("its preconditions or its effect fail" if not did else f"Alloy sees {', '.join(did)}"))
        if why:
            return why, verdict.seconds, verdict.text
    return "", verdict.seconds, verdict.text


def _state_refused(verdict: "AlloyPlanVerdict", i: int, name: str) -> str:
    """Why Alloy refuses configuration i of a verdict ("" when it does not), named `name`."""
    if not verdict.formed[i]:
        return f"{name} is not well formed"
    if not verdict.valid[i]:
        return f"{name} is not valid"
    if not verdict.lossless[i]:
        return f"a client request could be lost in {name}: a proxy is absent or its requests reach no protocol"
    if not verdict.stable[i]:
        return f"a connector the slice relies on is unsatisfied in {name}"
    return ""


def _chains(k: int) -> list[list[int]]:
    """Paths through the subsets of a batch of `k` steps (bit masks) that take every move
    (`batches.moves`) once: each path adds one step at a time."""
    unused = set(moves(k))
    out = []
    while unused:
        mask, j = min(unused)
        path = [mask]
        while j >= 0:
            unused.discard((mask, j))
            mask |= 1 << j
            path.append(mask)
            j = next((i for i in range(k) if (mask, i) in unused), -1)
        out.append(path)
    return out


def _batch_module(plan: Plan, first: int, last: int) -> tuple[Plan, list[Action | None], list[int]]:
    """The batch of steps `first`..`last` as one module's states and moves: every subset of its
    steps done from the state before it (each path of `_chains` in turn), the step of each move,
    None between two paths; and the index of every state that ends a move."""
    steps = plan.steps[first - 1:last]
    states = {0: plan.states[first - 1]}
    for mask in range(1, 1 << len(steps)):
        j = mask.bit_length() - 1
        states[mask] = effect(plan.system, states[mask & ~(1 << j)], steps[j])
    configs: list[Configuration] = []
    actions: list[Action | None] = []
    for path in _chains(len(steps)):
        if configs:
            actions.append(None)
        configs.append(states[path[0]])
        for a, b in zip(path, path[1:]):
            actions.append(steps[(a ^ b).bit_length() - 1])
            configs.append(states[b])
    module = dc_replace(plan, steps=list(steps), states=configs, stable=[], notes=[])
    return slice_plan(module), actions, [i for i, a in enumerate(actions) if a is not None]


def alloy_batches(plan: Plan, batches: Sequence[tuple[int, int]]) -> dict[str, Any]:
    """Alloy's judgement of each batch (checker.planning.batches): in every state some order of
    its steps reaches, the configuration valid, well formed and losing no request; every move
    an instance of its action. `refused` maps a batch (first, last) to Alloy's reason."""
    refused: dict[tuple[int, int], str] = {}
    seconds, states, moved = 0.0, 0, 0
    for first, last in batches:
        target, actions, ends = _batch_module(plan, first, last)
        verdict = alloy_plan_verdict(target.system, target.states, serving=target.serving,
                                     protocols=target.protocols, handover=target.handover, actions=actions)
        seconds += verdict.seconds
        states, moved = states + len(target.states), moved + len(ends)
        bad = [_state_refused(verdict, i, "a state some order reaches") for i in range(len(target.states))]
        why = next((b for b in bad if b), "")
        if not why:
            wrong = next((i for i in ends if actions[i].kind not in verdict.steps[i]), None)   # type: ignore[union-attr]
            if wrong is not None:
                why = f"in some order, {actions[wrong].describe()} is not an instance of its action"  # type: ignore[union-attr]
        if why:
            refused[(first, last)] = why
    return {"batches": len(batches), "states": states, "moves": moved, "seconds": round(seconds, 3),
            "refused": {f"{a}-{b}": why for (a, b), why in refused.items()}}
