"""Run an Alloy command in a worker process, so that a solve can be stopped.

A solve cannot be interrupted inside the JVM; the worker (multiprocessing, spawn) runs it
with its own JVM and is killed when the time limit passes.
"""
from __future__ import annotations

import multiprocessing as mp
import queue
from typing import Any, Mapping, Sequence

from checker.alloy.bridge import DEFAULT_SOLVER, CommandOutcome, get_backend
from checker.alloy.errors import AlloyError, AlloyTimeout, AlloyUnavailable


def _work(out: Any, modules: dict[str, str], main: str, command: str | None, solver: str,
          evals: Sequence[str]) -> None:
    try:

        outcomes = get_backend().run(modules, main, command, solver)
        for o in outcomes:
            if o.satisfiable:
                for expr in evals:
                    o.eval(expr)
            o._evaluator = None
        out.put(("ok", outcomes))
    except AlloyError as exc:
        out.put(("alloy", (exc.message, exc.module, exc.line, exc.column)))
    except AlloyUnavailable as exc:
        out.put(("unavailable", str(exc)))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent
        out.put(("error", f"{type(exc).__name__}: {exc}"))


def run_with_timeout(modules: Mapping[str, str], main: str, command: str | None = None,
                     solver: str = DEFAULT_SOLVER, timeout: float = 60.0,
                     evals: Sequence[str] = ()) -> list[CommandOutcome]:
    """Like `Backend.run`, in a worker process killed after `timeout` seconds
    (raising AlloyTimeout). `evals` are expressions evaluated in each solution before
    the worker exits; `outcome.eval` answers only those."""
    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    proc = ctx.Process(target=_work, args=(out, dict(modules), main, command, solver, list(evals)),
                       daemon=True)
    proc.start()
    try:
        kind, payload = out.get(timeout=timeout)
    except queue.Empty:
        proc.kill()
        proc.join(5)
        raise AlloyTimeout(command, timeout) from None
    proc.join(10)
    if proc.is_alive():
        proc.kill()
    if kind == "ok":
        return list(payload)
    if kind == "alloy":
        raise AlloyError(*payload)
    if kind == "unavailable":
        raise AlloyUnavailable(payload)
    raise RuntimeError(f"Alloy worker failed: {payload}")
