"""A run of a plan on the live system (docs/executor.md): check the live system against the
plan's state before the first step, perform each step with its wire conditions and read back
what it touched, then check the end on the wire and in the monitors' counters."""
from __future__ import annotations

import argparse
import sys
import threading
import time
from typing import Any, Optional

from .conditions import meets
from .context import Context, Interrupts, StepTiming, Writer
from .handlers import perform
from .observe import (
    as_state,
    check_touched,
    largest_gaps,
    last_violations,
    neighbourhood,
    observe,
    read_all,
    settle,
    unusual,
    violations,
    wait_status,
    wait_statuses,
)
from .plan_states import State
from .processes import end_held, end_orphans, forkable, hold, own_launcher, warm
from .remote import HostError
from .run_report import degraded_line, failed, interrupted, stale, write_report
from .runtime import Runtime, StepFailed
from .steps import EXIT_FAILED, EXIT_OK, batch_end, plan_steps, plural


def busy(timings: list[StepTiming]) -> float:
    """The seconds in which some step ran: the steps of a batch overlap, and count once."""
    total, reach = 0.0, float("-inf")
    for start, end in sorted((t.at, t.at + t.seconds) for t in timings):
        total += max(0.0, end - max(start, reach))
        reach = max(reach, end)
    return total


def confirmed(doc: dict[str, Any], args: argparse.Namespace, out: Writer) -> bool:
    """List the steps to apply; unless --yes, ask."""
    first, last = args.from_step, args.to_step
    if args.quiet_list and args.yes:      # a manager: its client has listed them
        return True
    print(f"applying steps {first}..{last} of the plan for {doc['system']} ({doc['fingerprint']})", file=out)
    for i, step in enumerate(plan_steps(doc)[first - 1:last], first):
        print(step.label(i), file=out)
    if args.yes:
        return True
    try:
        answer = input("Apply these steps to the running system? [y/N] ")
    except EOFError:
        answer = ""
    if answer.strip().lower() in ("y", "yes"):
        return True
    print("nothing done", file=out)
    return False


class Executor:
    """Applies a plan document's steps to the running system (docs/executor.md). A manager lends
    its long-lived `runtime`, its `launcher` and its `interrupts`; a plan script makes its own
    runtime and takes SIGINT and SIGTERM itself once the steps are confirmed."""

    def __init__(self, doc: dict[str, Any], args: argparse.Namespace, out: Writer = sys.stdout,
                 err: Writer = sys.stderr, runtime: Any = None, launcher: Any = None,
                 interrupts: Optional[Interrupts] = None) -> None:
        self.ctx = Context(doc, args, out, err, rt=runtime, launcher=launcher)
        self.own_runtime = runtime is None
        self.settled_at = 0.0           # when discovery had settled before the first step (monotonic)
        if interrupts is not None:
            self.ctx.interrupts = interrupts

    def apply(self, first: int) -> int:
        ctx = self.ctx
        if not confirmed(ctx.doc, ctx.args, ctx.out):
            return EXIT_FAILED
        t0 = time.monotonic()
        if self.own_runtime:
            ctx.interrupts.install()
            own_launcher(ctx, first, ctx.args.to_step)    # before rclpy: its imports overlap discovery
            ctx.rt = Runtime(ctx.doc["system"], ctx.args.namespace, ctx.args.timeout)
        try:
            return self._apply(first, t0)
        except KeyboardInterrupt:       # a second signal: at once, wherever the run was
            return interrupted(ctx, ctx.step, at_once=True)
        except (StepFailed, OSError) as e:   # outside a step: the start check, the final check
            return self._failed_outside(e)
        finally:
            end_held(ctx)
            if ctx.hosts is not None:
                ctx.hosts.close()
            if self.own_runtime and ctx.launcher is not None:
                ctx.launcher.close(wait=False)  # its children, the nodes started, stay
            if self.own_runtime:
                ctx.rt.close(exiting=True)

    def _apply(self, first: int, t0: float) -> int:
        ctx, last = self.ctx, self.ctx.args.to_step
        forks = forkable(ctx, first, last)
        warm(ctx, forks)
        hold(ctx, forks)
        hood = neighbourhood(ctx)
        refused = self._check_start(first, hood)
        if refused is not None:
            return refused
        if ctx.interrupts.stop:
            return interrupted(ctx, 0)
        why = end_orphans(ctx)
        if why:
            return failed(ctx, 0, None, f"before the first step: {why}")
        wait_statuses(ctx, hood & ctx.states[first - 1].components)
        # every monitor heard from, not only the neighbourhood's: a step can reach further on the
        # wire than in the model (a suspended protocol keeps its clients waiting); a node a step
        # creates joins them as it comes up (handlers.baseline)
        ctx.baseline = violations(ctx, ctx.states[first - 1].components)
        ctx.gaps = largest_gaps(ctx, ctx.states[first - 1].components)
        ctx.touched = {s.component for s in ctx.steps[first - 1:last]} & hood
        check_at = time.monotonic()
        ctx.say(f"the live system matches the plan's state before step {first} "
                f"({plural(len(hood), 'component')} checked in {check_at - t0:.2f} s: waiting for discovery "
                f"{self.settled_at - t0:.2f} s, the graph's last change {ctx.rt.graph_since - ctx.rt.started_at:.2f} s "
                f"after it began, reading {check_at - self.settled_at:.2f} s)")
        i = first
        while i <= last:
            end = batch_end(ctx, i, last)
            if not (self._step(i) if end == i else self._batch(i, end)):
                return failed(ctx, ctx.step, ctx.steps[ctx.step - 1], ctx.failure)
            i = end + 1
            if ctx.args.pause > 0 and i <= last and not ctx.interrupts.stop:
                ctx.rt.deadline = time.monotonic() + ctx.args.pause + 1.0
                ctx.rt.wait(lambda: ctx.interrupts.stop, ctx.args.pause)
            if ctx.interrupts.stop and i <= last:
                return interrupted(ctx, i - 1)
        return self._finish(first, hood, t0, check_at)

    def _failed_outside(self, e: Exception) -> int:
        """A reading before the first step or in the final check failed (a node that answered
        one call and not the next, the step's time up): a failure like a step's, reported."""
        ctx = self.ctx
        if ctx.step < 0:
            last = ctx.args.to_step
            return failed(ctx, last, ctx.steps[last - 1] if last else None, f"during the final check: {e}")
        if ctx.step == 0:
            return failed(ctx, 0, None, f"before the first step: {e}")
        return failed(ctx, ctx.step, ctx.steps[ctx.step - 1], str(e))

    def _check_start(self, first: int, hood: set[str]) -> Optional[int]:
        """Refuse (the exit status) unless the live system is the plan's state before `first`."""
        ctx = self.ctx
        start = ctx.states[first - 1]
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        settle(ctx, start.components & hood, ctx.args.discovery_timeout)
        self.settled_at = time.monotonic()
        seen = observe(ctx, hood)
        busy = sorted(c for c, o in seen.items() if o.lifecycle == "unresponsive")
        if busy:    # a node of a saturated host can take longer than one call's timeout to answer
            ctx.say(f"not answering within {ctx.args.timeout} s: {', '.join(busy)}; reading them again")
            seen.update(observe(ctx, busy))
        observed = as_state(ctx, seen)
        diffs = ctx.model.differences(start, observed, hood)
        if not diffs:
            return None
        unusual(ctx, seen)
        return stale(ctx, first, observed, diffs, hood)

    def _step(self, i: int) -> bool:
        """Perform step `i` and read back what the plan has touched; False (the reason in
        `ctx.failure`) when it failed or was interrupted."""
        ctx = self.ctx
        step = ctx.steps[i - 1]
        ctx.say(f"{step.label(i)} ...")
        s0, at = time.monotonic(), round(time.time(), 3)
        ctx.step = i
        try:
            perform(ctx, step, ctx.states[i - 1], ctx.states[i])
            ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
            check_touched(ctx, ctx.states[i], f"after step {i}")
        except (StepFailed, OSError) as e:     # OSError: a host's agent (HostError, naming the host), a file
            ctx.failure = str(e)
            ctx.failed_host = e.host if isinstance(e, HostError) else ""
            ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, False))
            return False
        except KeyboardInterrupt:
            ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, False))
            raise
        ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, True, step.action))
        ctx.say(f"      done in {time.monotonic() - s0:.3f} s")
        counted(ctx, i)
        return True

    def _batch(self, first: int, last: int) -> bool:
        """Perform steps `first`..`last` together (docs/executor.md#batches), each in a thread
        of its own with its wire conditions, then read back what the plan has touched; on the
        first failure the others stop at their next wait, and the batch fails with it."""
        ctx = self.ctx
        ctx.say(f"steps {first}–{last} together:")
        for i in range(first, last + 1):
            ctx.say(ctx.steps[i - 1].label(i))
        ctx.step, was = first, ctx.states[first - 1]
        failures: dict[int, str] = {}
        workers = [threading.Thread(target=self._together, args=(i, was, failures), daemon=True)
                   for i in range(first, last + 1)]
        s0 = time.monotonic()
        try:
            for w in workers:
                w.start()
            for w in workers:
                while w.is_alive():     # in steps, so that a signal is taken at once
                    w.join(0.05)
        except KeyboardInterrupt:       # a second signal: the others stop at their next wait
            ctx.rt.halt.set()
            for w in workers:
                w.join(ctx.args.timeout)
            raise
        finally:
            ctx.rt.halt.clear()
            ctx.timings.sort(key=lambda t: t.step)
        if failures:
            ctx.step = min(failures, key=lambda i: (failures[i].startswith("stopped: "), i))
            ctx.failure = failures[ctx.step]
            return False
        ctx.step = last
        try:
            ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
            check_touched(ctx, ctx.states[last], f"after steps {first}–{last}")
        except (StepFailed, OSError) as e:
            ctx.failure, ctx.failed_host = str(e), e.host if isinstance(e, HostError) else ""
            return False
        ctx.say(f"      steps {first}–{last} done in {time.monotonic() - s0:.3f} s")
        counted(ctx, last)
        return True

    def _together(self, i: int, was: State, failures: dict[int, str]) -> None:
        """Step `i` of a batch that began in state `was`: its wire conditions are judged against
        `was` with this step alone done (its steps commute: docs/soundness.md#batches)."""
        ctx, step = self.ctx, self.ctx.steps[i - 1]
        s0, at = time.monotonic(), round(time.time(), 3)
        try:
            perform(ctx, step, was, ctx.states.alone(was, i))
        except (StepFailed, OSError) as e:
            failures[i] = str(e)
            if isinstance(e, HostError):
                ctx.failed_host = e.host
            ctx.rt.halt.set()
            ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, False))
            return
        ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, True, step.action))
        ctx.say(f"      step {i} done in {time.monotonic() - s0:.3f} s")

    def _finish(self, first: int, hood: set[str], t0: float, check_at: float) -> int:
        """After the last step: the neighbourhood reads back as the plan's last state, the
        touched functionalities meet their assumptions on the wire, and no monitor's count moved
        (every monitor heard from at the start, and every node the plan created)."""
        ctx, last = self.ctx, self.ctx.args.to_step
        ctx.step = -1                   # the final check
        final_at = time.monotonic()
        end = ctx.states[last]
        normal = [(c, f["name"]) for c in sorted(ctx.touched & end.components)
                  for f in ctx.model.comps[c]["functionalities"] if (c, f["name"]) not in end.degraded]
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        unmet = [f"{c}.{f}" for c, f in normal if not wait_status(ctx, c, meets(f), ctx.args.wire_timeout)]
        # every component, not only the neighbourhood: the report says the whole configuration
        final, _ = read_all(ctx)
        wrong = ctx.model.differences(end, final, hood)
        if wrong:
            return failed(ctx, last, ctx.steps[last - 1] if last else None, "after the last step: " + "; ".join(wrong))
        seen_bad = counted(ctx, last)
        upto = "" if last == len(ctx.steps) else f"; stopped after step {last} as asked (--to-step)"
        done = last - first + 1
        now, steps = time.monotonic(), busy(ctx.timings)
        ctx.say(("no step" if done <= 0 else f"all {done} steps" if done != 1 else "the 1 step")
                + f" done in {now - t0:.2f} s (checking the live system {check_at - t0:.2f} s, steps "
                f"{steps:.2f} s, between steps {max(0.0, final_at - check_at - steps):.2f} s, "
                f"the final check {now - final_at:.2f} s){upto}")
        line = degraded_line(ctx, first)
        if line:
            ctx.say(line)
        if unmet or seen_bad:
            if unmet:
                ctx.warn(f"but on the wire, the assumptions of {', '.join(unmet)} are not met")
            for c, n in sorted(seen_bad.items()):
                last = ctx.last_violation.get(c)
                ctx.warn(f"but the monitor of {c} saw {plural(n, 'violation')} of a normal mode's assumption "
                         f"during the run (first seen after step {ctx.violated[c]})"
                         + (f"; the last began {in_run(ctx, last)}" if last else ""))
            write_report(ctx, "violated", first, observed=final)
            return EXIT_FAILED
        heard = len(ctx.baseline)
        ctx.say("on the wire: every functionality the plan touched meets its assumptions, and "
                + (f"none of the {heard} monitors heard from saw" if heard != 1 else
                   "the 1 monitor heard from did not see")
                + " a normal mode's assumption violated during the run")
        write_report(ctx, "done", first, observed=final)
        return EXIT_OK


def counted(ctx: Context, i: int) -> dict[str, int]:
    """Each counted monitor's violations since its baseline (those whose count moved), the step
    after which each was first seen noted in `ctx.violated`."""
    now = violations(ctx, ctx.baseline)
    moved = {c: now[c] - n for c, n in ctx.baseline.items() if now.get(c, n) > n}
    for c in moved:
        ctx.violated.setdefault(c, i)
    ctx.violations.update(moved)
    ctx.last_violation.update(last_violations(ctx, moved))
    return moved


def in_run(ctx: Context, last: str) -> str:
    """A monitor's `last_violation` ("<wall clock> <functionality>: why") with its time placed
    among the steps' (the nodes and this executor read one clock, or clocks kept in step)."""
    at, _, what = last.partition(" ")
    try:
        t = float(at)
    except ValueError:
        return last
    past = [s for s in ctx.timings if s.at <= t]
    if not past:
        return f"before step {ctx.timings[0].step if ctx.timings else 1}: {what}"
    s = past[-1]
    if t <= s.at + s.seconds:
        return f"{t - s.at:.2f} s into step {s.step}: {what}"
    return f"{t - s.at - s.seconds:.2f} s after step {s.step}: {what}"
