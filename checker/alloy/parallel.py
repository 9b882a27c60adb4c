"""A second analyzer for the slices of one check, in a helper process (README, "Alloy").

The slices of a configuration are independent, and the analyzer is single-threaded (one
JVM's translation is not safe to share between threads), so a check of many slices uses
a second core through a second process with its own JVM. The helper is spawned before
the main process starts its own analyzer, so the two start-ups overlap; both then take
slices from one counter until none is left. A helper that is late, fails or dies costs
nothing but its start: the main process judges every slice the helper did not answer.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import queue
import time
from typing import Any, Callable, Optional

from .bridge import CommandOutcome

# below this many slices the helper's start-up (about 1.5 s) is not paid back
MIN_SLICES = 24
ENV = "RECONF_ALLOY_PROCESSES"   # 1: judge every slice in this process

Judged = tuple[bool, list[tuple[str, ...]], float, float]   # satisfiable, unsatisfied, solve s, front end s


def helpers_wanted(slices: int) -> bool:
    """Whether a check of `slices` slices should start a helper: two cores or more, enough
    slices, and not switched off by RECONF_ALLOY_PROCESSES=1."""
    setting = os.environ.get(ENV, "").strip()
    if setting == "1":
        return False
    return slices >= MIN_SLICES and (os.cpu_count() or 1) >= 2


def judge_text(bridge: Any, text: str, solver: str, main: str) -> Judged:
    """`check Valid` of one slice; for a counterexample, the failing (functionality, assumption)."""
    clock = time.perf_counter()
    (outcome,) = bridge.run({main: text}, main, "Valid", solver, constants=True)
    pairs = sorted(outcome.eval("unsatisfied")) if outcome.satisfiable else []
    return _judged(outcome, pairs, time.perf_counter() - clock)


def _judged(outcome: CommandOutcome, pairs: list[tuple[str, ...]], spent: float) -> Judged:
    return bool(outcome.satisfiable), pairs, outcome.elapsed, max(0.0, spent - outcome.elapsed)


def _serve(texts: Any, results: Any, counter: Any, solver: str, main: str) -> None:
    """The helper: start an analyzer, then judge slices by the shared counter until none is left."""
    from .bridge import AlloyBridge
    from .errors import AlloyError

    try:
        bridge = AlloyBridge.get()
        batch = texts.get(timeout=600)
    except BaseException:  # noqa: BLE001 - the main process judges what the helper does not
        results.put(("done", -1, None))
        return
    while True:
        with counter.get_lock():
            i = counter.value
            counter.value += 1
        if i >= len(batch):
            break
        try:
            results.put(("ok", i, judge_text(bridge, batch[i], solver, main)))
        except AlloyError as err:
            results.put(("alloy", i, (err.message, err.module, err.line, err.column)))
        except BaseException as err:  # noqa: BLE001
            results.put(("error", i, f"{type(err).__name__}: {err}"))
    results.put(("done", -1, None))


class Helper:
    """A helper process judging slices beside this one."""

    def __init__(self, solver: str, main: str) -> None:
        ctx = mp.get_context("spawn")
        self.texts: Any = ctx.Queue()
        self.results: Any = ctx.Queue()
        self.counter: Any = ctx.Value("i", 0)
        self.proc = ctx.Process(target=_serve, args=(self.texts, self.results, self.counter, solver, main),
                                daemon=True, name="reconf-alloy-helper")
        self.proc.start()

    def judge_all(self, texts: list[str], mine: Callable[[int], Judged]) -> tuple[dict[int, Judged], int]:
        """Every slice judged, by this process (`mine(i)`) or the helper: the verdicts by index,
        and how many the helper judged. A slice the helper failed on is judged again here, so
        its error is this process's own."""
        self.texts.put(texts)
        out: dict[int, Judged] = {}
        while True:
            with self.counter.get_lock():
                i = self.counter.value
                self.counter.value += 1
            if i >= len(texts):
                break
            out[i] = mine(i)
        helped = 0
        while len(out) < len(texts):
            try:
                kind, i, payload = self.results.get(timeout=0.5)
            except queue.Empty:
                if self.proc.is_alive():
                    continue
                kind, i, payload = "done", -1, None
            if kind == "ok":
                out[i] = payload
                helped += 1
            elif kind == "done":     # the helper stopped: whatever it left is judged here
                for j in range(len(texts)):
                    if j not in out:
                        out[j] = mine(j)
            else:                    # judged again here, where an error is reported at its span
                out[i] = mine(i)
        return out, helped

    def close(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join(5)
        for q in (self.texts, self.results):
            q.cancel_join_thread()
            q.close()


def start_helper(slices: int, solver: str, main: str) -> Optional[Helper]:
    """A helper for `slices` slices when it pays (`helpers_wanted`), else None."""
    if not helpers_wanted(slices):
        return None
    try:
        return Helper(solver, main)
    except OSError:
        return None
