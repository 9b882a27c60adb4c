"""What a run says when it ends: the run report (JSON, read by `reconf recover`), and on a
failure or a stale plan the observed configuration, judged by the same semantics, with the
way back (docs/executor.md#failure-and-recovery)."""
from __future__ import annotations

import json
import os
import time
from typing import Any, Optional

from .context import Context, StepTiming
from .observe import Observed, largest_gaps, read_all, unusual
from .plan_states import State, degraded_spans
from .processes import list_started
from .runtime import StepFailed
from .steps import EXIT_FAILED, EXIT_INTERRUPTED, Step


def write_report(ctx: Context, outcome: str, first: int, observed: Optional[State],
                 failed_step: Optional[int] = None, why: Optional[str] = None) -> str:
    """Write the run's report (JSON, atomically); return its path ("" when none is asked for)."""
    path = ctx.args.report or (f"reconf-{ctx.doc['system']}-{outcome}.json" if outcome != "done" else "")
    if not path:
        return ""
    body: dict[str, Any] = {
        "format_version": 1, "tool": "reconf", "kind": "run-report", "outcome": outcome,
        "system": ctx.doc["system"], "fingerprint": ctx.doc["fingerprint"], "from_step": first,
        "failed_step": failed_step, "reason": why,
        "failed_host": ctx.failed_host or None,     # the host whose agent failed the step (docs/hosts.md)
        "observed": None if observed is None else observed.to_doc(),
        "observed_at": None if observed is None else ctx.read_at,    # when that reading began (wall clock)
        "unread": sorted(ctx.unread),     # components whose node did not answer: not in `observed`, not known
        "observed_valid": None if observed is None else not ctx.model.failures(observed),
        "timings": [t.to_doc() for t in ctx.timings],
        # each monitor that saw a normal mode's assumption violated: how often, first after which
        # step, and its last violation as its status said it (when it began, on the wall clock; why)
        "violated": {c: {"violations": ctx.violations.get(c, 0), "after_step": i,
                         "last": ctx.last_violation.get(c)} for c, i in sorted(ctx.violated.items())},
        "gaps": gaps(ctx),
        "started": {c: info.to_doc() for c, info in ctx.started.items()},
        "placed": {c: n for c, n in ctx.names.placed.items() if "@" not in n} if ctx.rt is not None else {},
        "plan_document": ctx.doc}
    if ctx.interrupts.stop:
        body["interrupted_by"] = ctx.interrupts.by
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(body, fh, indent=1, sort_keys=True)
    os.replace(tmp, path)
    print(f"report: {path}", file=ctx.err if outcome != "done" else ctx.out)
    return path


def gaps(ctx: Context) -> dict[str, dict[str, Any]]:
    """Each monitored input's largest wait for data as its node's last status says, and whether
    the run saw it (larger than before the first step, or on a node the run started): "comp.port"
    -> {"seconds", "during_run"}. Its node's status comes once a second: a gap of the last
    second before the report may not be in it yet."""
    if ctx.rt is None:
        return {}
    now = largest_gaps(ctx, ctx.baseline)
    return {k: {"seconds": round(s, 3), "during_run": s > ctx.gaps.get(k, 0.0)} for k, s in sorted(now.items())}


def stale(ctx: Context, first: int, observed: State, diffs: list[str], hood: set[str]) -> int:
    """Refuse a plan whose state before step `first` is not what the live system shows; say
    which state of the plan it is, if any."""
    ctx.warn(f"refusing to apply: the live system does not match the plan's state before step {first}:")
    for d in diffs:
        ctx.warn(f"  - {d}")
    matches = [i for i, s in enumerate(ctx.states) if not ctx.model.differences(s, observed, hood)]
    if matches:
        i = matches[-1]
        ctx.warn(f"It matches the state after step {i}" + (" (the plan's last: it was applied already)"
                                                          if i == len(ctx.steps) else "")
                 + (f"; resume with --from-step {i + 1}" if i < len(ctx.steps) else "") + ".")
    else:
        ctx.warn("Plan again from the running system (the plan is stale).")
    write_report(ctx, "stale", first, observed=observed)
    return EXIT_FAILED


def _judge(ctx: Context, i: int, observed: State, seen: dict[str, Observed]) -> None:
    """Print the observed configuration, whether it is valid, and which plan state it is."""
    ctx.warn("Observed configuration (read from the running nodes):\n    " + observed.describe())
    unusual(ctx, seen)
    bad = ctx.model.failures(observed)
    if bad:
        ctx.warn("It is NOT valid:")
        for b in bad:
            ctx.warn(f"  - {b}")
    else:
        ctx.warn("It is valid: every assumption of every present functionality holds in the model.")
    if i == 0 and not ctx.model.differences(ctx.states[0], observed, ctx.model.comps):
        ctx.warn("It is the plan's first state: nothing was done.")
    for k, name in ((i - 1, "before"), (i, "after")) if i else ():
        if not ctx.model.differences(ctx.states[k], observed, ctx.model.comps):
            ctx.warn(f"It is the plan's state {name} step {i}.")


def _observe_all(ctx: Context) -> tuple[Optional[State], dict[str, Observed]]:
    try:
        return read_all(ctx)
    except StepFailed as e:
        ctx.warn(f"could not observe the system after the failure: {e}")
        return None, {}


def failed(ctx: Context, i: int, step: Optional[Step], why: str) -> int:
    """Step `i` failed: read every component, say what the system is now and how to recover."""
    ctx.warn(f"step {i} ({step.describe()}) FAILED: {why}" if step is not None else f"FAILED: {why}")
    observed = _report_observed(ctx, i)
    path = write_report(ctx, "failed", i, observed=observed, failed_step=i, why=why)
    _how_to_recover(ctx, path)
    return EXIT_FAILED


def interrupted(ctx: Context, i: int, at_once: bool = False) -> int:
    """The run was interrupted (docs/executor.md#interrupted): after step `i` (0: before the
    first), or, `at_once`, during it. Read every component, say what the system is now, name
    the processes the run started, write the report. Another signal meanwhile leaves the
    configuration unread, and says so."""
    by = ctx.interrupts.by or "a signal"
    if i < 0:                           # during the final check: every step was done
        i, where = ctx.args.to_step, "during the final check"
        at_once = False
    else:
        where = (f"during step {i} ({ctx.steps[i - 1].describe()})" if at_once and i else
                 f"after step {i}" if i else "before the first step")
    ctx.warn(f"INTERRUPTED by {by} {where}" + (": stopped at once" if at_once else
                                                ": stopped at the step's end" if i and "check" not in where else ""))
    if at_once and i:
        ctx.timings = [t for t in ctx.timings if t.step != i] + [StepTiming(i, time.time(), 0.0, False)]
    observed: Optional[State] = None
    try:
        observed = _report_observed(ctx, i)
    except KeyboardInterrupt:
        ctx.warn("interrupted again: the configuration was not read")
        list_started(ctx, False)
    path = write_report(ctx, "interrupted", i, observed=observed, failed_step=i if at_once and i else None,
                        why=f"interrupted by {by} {where}")
    if observed is not None:
        _how_to_recover(ctx, path)
    return EXIT_INTERRUPTED


def _report_observed(ctx: Context, i: int) -> Optional[State]:
    """Every component read and judged; the processes started named (those never activated
    ended: they are in no configuration); the configuration observed."""
    ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
    observed, seen = _observe_all(ctx)
    if observed is not None:
        _judge(ctx, i, observed, seen)
    list_started(ctx, ctx.args.stop_started, None if observed is None else observed.components)
    if ctx.started and ctx.args.stop_started and observed is not None:
        observed = _observe_all(ctx)[0]
    return observed


def _how_to_recover(ctx: Context, path: str) -> None:
    ctx.warn(f"To recover, plan from the observed configuration:\n"
             f"    reconf recover {path} --yes           (on to the plan's target)\n"
             f"    reconf recover {path} --back --yes    (back to the plan's start)\n"
             f"    (-o recover.py writes the plan as a script instead)")


def degraded_line(ctx: Context, first: int) -> str:
    """A whole plan's run: each functionality that served before it and was degraded, for how long
    by the steps' times, next to the plan's estimate, the longest three first, and in all (""
    for a run of part of a plan, or a plan without an estimate)."""
    estimate = ctx.doc["plan"].get("seconds") or {}
    if not estimate or first != 1 or ctx.args.to_step != len(ctx.steps):
        return ""
    planned = {f"{f['component']}.{f['functionality']}": float(f["seconds"]) for f in estimate.get("functionalities", [])}
    timed = [(t.step, t.at, t.at + t.seconds, t.ok) for t in ctx.timings]
    removes = {t.step for t in ctx.timings if ctx.steps[t.step - 1].action == "remove"}
    served = ctx.states[0].components
    spans = degraded_spans(ctx.states, timed, removes, max((t[2] for t in timed), default=0.0))
    measured = {n: sum(b - a for a, b in s) for n, s in spans.items() if n.split(".", 1)[0] in served}
    measured = {n: s for n, s in measured.items() if s > 0}
    if not measured and not planned:
        return "degraded on the wire: no functionality that served before the run (the plan expected none)"
    names = sorted(set(measured) | set(planned), key=lambda n: (-measured.get(n, 0.0), n))
    shown = ", ".join(f"{n} {measured.get(n, 0.0):.2f} s (plan ~{planned.get(n, 0.0):.2f} s)" for n in names[:3])
    return (f"degraded on the wire, by the steps' times: {shown}{', …' if len(names) > 3 else ''}; "
            f"{sum(measured.values()):.2f} s in all (plan ~{sum(planned.values()):.2f} s)")
