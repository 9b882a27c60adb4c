"""Two engines, one verdict: Alloy proves, the Python engine explains, and they must agree.

A disagreement is an internal error (exit 2) that shows both verdicts: it means the
meta-model, the instance generator or the Python engine is wrong, and no answer is given."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Callable, Optional, TypeVar

from checker.alloy.errors import AlloyError, AlloyUnavailable
from checker.alloy.instance import AlloyVerdict, PendingVerdict
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import Evaluation, evaluate, witnesses
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import System
from reconf_dsl.span import Span

Failing = tuple[tuple[str, str, int], ...]


class Engine(str, Enum):
    """Which engines judge: the Python engine, Alloy, or both (which must then agree). The one
    name of the choice every `--engine` option makes and every judgement reads."""

    PYTHON = "python"
    ALLOY = "alloy"
    BOTH = "both"

    @property
    def python(self) -> bool:
        """Whether the Python engine judges."""
        return self is not Engine.ALLOY

    @property
    def alloy(self) -> bool:
        """Whether Alloy judges."""
        return self is not Engine.PYTHON

    def says(self) -> str:
        """How a progress line says where the judging happens."""
        return " in the Alloy Analyzer" if self.alloy else ""

# A connector with more publishers than this is shown in a slice by one witness that
# satisfies it (checker.semantic_model.semantics.witnesses): the hub of a 20,000-component fan-in reads
# 10,000 publishers, which would make its slice as large as the rest of the check together.
WIDE = 16


class EngineUnavailable(Exception):
    def __init__(self, diagnostic: Diagnostic):
        self.diagnostic = diagnostic


class AlloyTooLarge(EngineUnavailable):
    """The system is beyond what this Alloy build can translate (its atom capacity, or the heap)."""


class EnginesDisagree(Exception):
    def __init__(self, diagnostic: Diagnostic):
        self.diagnostic = diagnostic


@dataclass
class Judgement:
    python: Evaluation
    valid: bool
    engines: dict[str, Any] = field(default_factory=dict)
    warnings: list[Diagnostic] = field(default_factory=list)

    def how(self) -> str:
        al = self.engines.get("alloy")
        if al is None:
            return " (Python engine)"
        if al.get("verdict") == "not run":
            return " (Python engine; too large for Alloy, see the warning)"
        if "python" not in self.engines:
            return " (evaluated by Alloy)"
        return " (proved by Alloy's evaluator; explained by the Python engine)"

    def timing(self) -> tuple[list[tuple[str, float]], dict[str, str]]:
        """Where the judgement's wall time went, in the order it went there: writing the
        instances for Alloy (its threads judge each as soon as it is written), the Python
        engine (meanwhile, Alloy judges), then waiting for Alloy's start (the JVM and the
        evaluation module, if not done by then) and for its last instances; and what the
        analyzer's part was made of: its threads' time reading the instances and evaluating in
        them, summed (see `report.timing_note`)."""
        al = self.engines.get("alloy", {}).get("timing")
        python = [("Python engine", self.engines["python"]["seconds"])] if "python" in self.engines else []
        if not al:
            return python, {}
        out = [("rendering", al["render"]), *python, ("Alloy start", al["start"]), ("Alloy", al["judging"])]
        n, threads = al["instances"], al.get("threads", 1)
        on = f" on {threads} threads" if threads > 1 else ""
        detail = (f"{n} instance{'s' if n != 1 else ''}{on}, read {al['read']:.2f} s, "
                  f"evaluated {al['evaluate']:.2f} s")
        return out, {"Alloy": detail}


def python_failing(ev: Evaluation) -> Failing:
    return tuple(sorted((r.component, r.functionality, r.index) for r in ev.unsatisfied))


def judge(system: System, config: Configuration, engine: Engine = Engine.BOTH,
          python: Optional[Evaluation] = None) -> Judgement:
    """Judge `config` of `system` by `engine`: with Alloy, its instances are written first and
    judged on the analyzer's threads while the Python engine runs. `python`: the Python
    engine's evaluation of this very configuration, made before (the language server's, as
    the user typed), used instead of evaluating again."""
    pending: Optional[PendingVerdict] = None
    too_large: Optional[AlloyTooLarge] = None
    try:
        pending = _alloy(system, lambda: _start_alloy(system, config)) if engine.alloy else None
    except AlloyTooLarge as e:
        too_large = e
    try:
        started = time.perf_counter()
        ev = python if python is not None and python.system is system and python.config == config \
            else evaluate(system, config)
        seconds = time.perf_counter() - started
        outcome = _alloy(system, lambda: _alloy_outcome(pending.result())) if pending is not None else None
    except AlloyTooLarge as e:
        too_large = e
    finally:
        if pending is not None:
            pending.close()
    engines: dict[str, Any] = {}
    if engine.python:
        engines["python"] = {"verdict": "safe" if ev.valid else "unsafe", "seconds": round(seconds, 4),
                             "unsatisfied": [list(x) for x in python_failing(ev)]}
    if too_large is not None:
        if engine is not Engine.BOTH:
            raise too_large
        # Both engines were asked for, the Python one has answered: say plainly that this answer
        # has no Alloy proof behind it, rather than refuse to answer.
        engines["alloy"] = {"verdict": "not run", "reason": too_large.diagnostic.message}
        return Judgement(ev, ev.valid, engines, [too_large.diagnostic])
    if outcome is None:
        return Judgement(ev, ev.valid, engines)
    valid, failing, engines["alloy"] = outcome
    if engine is Engine.BOTH and (valid != ev.valid or failing != python_failing(ev)):
        raise EnginesDisagree(Diagnostic(
            "RC300", Severity.ERROR,
            f"the engines disagree: Python says {'safe' if ev.valid else 'unsafe'}, "
            f"Alloy says {'safe' if valid else 'unsafe'}", system.span,
            notes=(f"Python: unsatisfied {list(python_failing(ev)) or 'none'}",
                   f"Alloy: unsatisfied {list(failing) or 'none'}",
                   "this is a bug in reconf: please report it with the .arch file")))
    return Judgement(ev, valid, engines)


def _start_alloy(system: System, config: Configuration) -> PendingVerdict:
    clock = time.perf_counter()
    keep = witnesses(system, config, WIDE)
    pending = PendingVerdict(system, config, keep=keep)
    pending.render += time.perf_counter() - clock - pending.render   # the witnesses are part of the writing
    return pending


def _alloy_outcome(v: AlloyVerdict) -> tuple[bool, Failing, dict[str, Any]]:
    return v.valid, tuple(sorted(v.unsatisfied)), {"verdict": "safe" if v.valid else "unsafe",
                                                    "seconds": round(v.seconds, 4), "method": "evaluation",
                                                    "timing": v.timing(),
                                                    "unsatisfied": [list(x) for x in sorted(v.unsatisfied)]}


_T = TypeVar("_T")


def _alloy(system: System, work: Callable[[], _T]) -> _T:
    """`work()`, with what the analyzer raises said as reconf's diagnostics: no Java or jar
    (RC301), a module it rejects (RC302), a system too large for it (RC303)."""
    try:
        return work()
    except AlloyUnavailable as e:
        raise EngineUnavailable(Diagnostic("RC301", Severity.ERROR, str(e), Span.unknown("<alloy>"),
                                           notes=("or use --engine python",))) from None
    except Exception as e:  # noqa: BLE001 - Java errors arrive as JPype exceptions
        if not _too_large(e):
            if isinstance(e, AlloyError):
                raise EngineUnavailable(Diagnostic(
                    "RC302", Severity.ERROR, f"Alloy rejected the generated module: {e}",
                    getattr(e, "span", None) or Span.unknown(e.module or "<alloy>"),
                    notes=("this is a bug in reconf: please report it",))) from None
            raise
        raise AlloyTooLarge(Diagnostic(
            "RC303", Severity.WARNING,
            f"{system.name} is too large for the Alloy Analyzer here ({_first_line(e)}); "
            "its safety rests on the Python engine alone", Span.unknown("<alloy>"),
            notes=("RECONF_ALLOY_XMX raises the heap; Alloy's atom capacity is fixed",))) from None


def _too_large(e: BaseException) -> bool:
    text = f"{type(e).__name__}: {e}"
    return "capacity exceeded" in text or "OutOfMemoryError" in text


def _first_line(e: BaseException) -> str:
    return (str(e).strip().splitlines() or [type(e).__name__])[0][:160]


def unavailable_diagnostic(e: Exception) -> Optional[Diagnostic]:
    if isinstance(e, (EngineUnavailable, EnginesDisagree)):
        return e.diagnostic
    return None
