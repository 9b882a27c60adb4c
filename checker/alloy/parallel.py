"""A second analyzer in a helper process, for many independent modules (docs/soundness.md,
"Slicing a large check").

The slices of a configuration, and the windows of a plan, are independent modules, and the
analyzer is single-threaded (one JVM's translation is not safe to share between threads),
so a check or a plan verification of many modules uses a second core through a second
process with its own JVM. The helper is spawned before the main process starts its own
analyzer, so the two start-ups overlap, and it serves every batch of the process after
that; in a batch both take modules from one counter until none is left. A helper that is
late, fails or dies costs nothing but its start: the main process judges every module the
helper did not answer.
"""
from __future__ import annotations

import atexit
import multiprocessing as mp
import os
import queue
import time
from typing import Any, Callable, NamedTuple, Optional

from checker.alloy.bridge import get_backend

# below this many modules in a batch the helper's start-up (about 1.5 s) is not paid back
MIN_MODULES = 24
ENV = "RECONF_ALLOY_PROCESSES"   # 1: judge every module in this process


class Job(NamedTuple):
    """One module to judge: run `command` of `text` (as module `main`), and, when it has an
    instance, evaluate `evals` in it."""

    main: str
    text: str
    command: str
    evals: tuple[str, ...] = ()
    constants: bool = True      # every relation a constant (instance and plan modules)


class Judged(NamedTuple):
    satisfiable: bool
    values: dict[str, list[tuple[str, ...]]]    # each of the job's evals, when satisfiable
    solve: float                                # the solver's seconds
    front: float                                # the rest: the front end's seconds


def helpers_wanted(modules: int, minimum: int = MIN_MODULES) -> bool:
    """Whether a batch of `modules` should have a helper: two cores or more, at least
    `minimum` modules, and not switched off by RECONF_ALLOY_PROCESSES=1."""
    if os.environ.get(ENV, "").strip() == "1":
        return False
    return modules >= minimum and (os.cpu_count() or 1) >= 2


def judge(bridge: Any, job: Job, solver: str) -> Judged:
    """`job` run by `bridge`."""
    clock = time.perf_counter()
    (outcome,) = bridge.run({job.main: job.text}, job.main, job.command, solver, constants=job.constants)
    values = {e: sorted(outcome.eval(e)) for e in job.evals} if outcome.satisfiable else {}
    spent = time.perf_counter() - clock
    return Judged(bool(outcome.satisfiable), values, outcome.elapsed, max(0.0, spent - outcome.elapsed))


def _claim(batch: Any, counter: Any, mine: int, size: int) -> int:
    """The next module of batch `mine` to judge, or -1 when the batch is done or replaced."""
    with counter.get_lock():
        if batch.value != mine or counter.value >= size:
            return -1
        i = int(counter.value)
        counter.value += 1
        return i


def _serve(jobs: Any, results: Any, batch: Any, counter: Any, solver: str) -> None:
    """The helper: start an analyzer, then judge modules of each batch it is sent."""
    try:
        bridge = get_backend()
    except BaseException:  # noqa: BLE001 - the main process judges what the helper does not
        return
    while True:
        try:
            number, work = jobs.get()
        except (EOFError, OSError):
            return
        while (i := _claim(batch, counter, number, len(work))) >= 0:
            try:
                results.put((number, "ok", i, judge(bridge, work[i], solver)))
            except BaseException as err:  # noqa: BLE001 - judged again in the main process
                results.put((number, "failed", i, f"{type(err).__name__}: {err}"))
        results.put((number, "done", -1, None))


class Helper:
    """A helper process judging modules beside this one, batch after batch."""

    def __init__(self, solver: str) -> None:
        ctx = mp.get_context("spawn")
        self.solver = solver
        self.jobs: Any = ctx.Queue()
        self.results: Any = ctx.Queue()
        self.batch: Any = ctx.Value("i", 0)
        self.counter: Any = ctx.Value("i", 0)
        self.proc = ctx.Process(target=_serve, args=(self.jobs, self.results, self.batch, self.counter, solver),
                                daemon=True, name="reconf-alloy-helper")
        self.proc.start()
        self.number = 0

    def judge_all(self, work: list[Job], mine: Callable[[int], Judged]) -> tuple[list[Judged], int]:
        """Every module of `work` judged, here (`mine(i)`) or by the helper: the verdicts in
        order, and how many the helper judged. A module the helper failed on is judged again
        here, so its error is this process's own."""
        self.number += 1
        number = self.number
        with self.counter.get_lock():
            self.batch.value = number
            self.counter.value = 0
        self.jobs.put((number, work))
        out: dict[int, Judged] = {}
        while (i := _claim(self.batch, self.counter, number, len(work))) >= 0:
            out[i] = mine(i)
        helped = 0
        while len(out) < len(work):
            try:
                got, kind, i, payload = self.results.get(timeout=0.5)
            except queue.Empty:
                if self.proc.is_alive():
                    continue
                got, kind, i, payload = number, "done", -1, None
            if got != number:
                continue                 # a late answer of an earlier batch
            if kind == "ok":
                out[i] = payload
                helped += 1
            elif kind == "done":         # whatever the helper left is judged here
                for j in range(len(work)):
                    if j not in out:
                        out[j] = mine(j)
            else:
                out[i] = mine(i)
        with self.counter.get_lock():
            self.batch.value = -number   # the helper stops claiming from this batch
        return [out[i] for i in range(len(work))], helped

    def close(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join(5)
        for q in (self.jobs, self.results):
            q.cancel_join_thread()
            q.close()


_SHARED: dict[str, Helper] = {}


def helper_for(modules: int, solver: str, minimum: int = MIN_MODULES) -> Optional[Helper]:
    """This process's helper for a batch of `modules` (started on the first batch that pays,
    `helpers_wanted`), or None."""
    if not helpers_wanted(modules, minimum):
        return None
    helper = _SHARED.get(solver)
    if helper is not None and helper.proc.is_alive():
        return helper
    try:
        helper = _SHARED[solver] = Helper(solver)
    except OSError:
        return None
    return helper


def judge_many(work: list[Job], solver: str, bridge: Any = None,
               on_error: Callable[[int, BaseException], BaseException] | None = None,
               minimum: int = MIN_MODULES) -> tuple[list[Judged], int, int]:
    """Every module of `work` judged, by this process's analyzer and, when it pays (`minimum`
    modules or more), a helper: the verdicts in order, how many processes judged, and how
    many modules the helper took. `on_error(i, err)` gives the exception to raise for an
    error in module i."""
    helper = helper_for(len(work), solver, minimum) if bridge is None else None
    bridge = bridge or get_backend()

    def mine(i: int) -> Judged:
        try:
            return judge(bridge, work[i], solver)
        except Exception as err:  # noqa: BLE001 - mapped by the caller
            if on_error is None:
                raise
            raise on_error(i, err) from None

    if helper is None:
        return [mine(i) for i in range(len(work))], 1, 0
    verdicts, helped = helper.judge_all(work, mine)
    return verdicts, 2, helped


@atexit.register
def _close_all() -> None:
    for helper in _SHARED.values():
        helper.close()
    _SHARED.clear()
