"""Two engines, one verdict: Alloy proves, the Python engine explains, and they must agree.

A disagreement is an internal error (exit 2) that shows both verdicts: it means the
meta-model, the instance generator or the Python engine is wrong, and no answer is given."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Optional

from checker.alloy import AlloyError, AlloyUnavailable, alloy_verdict
from checker.model.config import Configuration
from checker.model.semantics import Evaluation, evaluate, witnesses
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
# satisfies it (checker.model.semantics.witnesses): the hub of a 20,000-component fan-in reads
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
        """Where the judgement's wall time went, in order (the Python engine, Alloy's start,
        writing the instances, the analyzer reading them and evaluating in them), and what
        the analyzer's part was made of (see `report.timing_note`)."""
        out: list[tuple[str, float]] = []
        if "python" in self.engines:
            out.append(("Python engine", self.engines["python"]["seconds"]))
        al = self.engines.get("alloy", {}).get("timing")
        if not al:
            return out, {}
        out += [("Alloy start", al["start"]), ("rendering", al["render"]), ("Alloy", al["judging"])]
        n = al["instances"]
        detail = f"{n} instance{'s' if n != 1 else ''}, read {al['read']:.2f} s, evaluated {al['evaluate']:.2f} s"
        return out, {"Alloy": detail}


def python_failing(ev: Evaluation) -> Failing:
    return tuple(sorted((r.component, r.functionality, r.index) for r in ev.unsatisfied))


def judge(system: System, config: Configuration, engine: Engine = Engine.BOTH) -> Judgement:
    started = time.perf_counter()
    ev = evaluate(system, config)
    engines: dict[str, Any] = {}
    if engine.python:
        engines["python"] = {"verdict": "safe" if ev.valid else "unsafe",
                             "seconds": round(time.perf_counter() - started, 4),
                             "unsatisfied": [list(x) for x in python_failing(ev)]}
    if not engine.alloy:
        return Judgement(ev, ev.valid, engines)
    try:
        valid, failing, info = alloy_judgement(system, config)
    except AlloyTooLarge as e:
        if engine is not Engine.BOTH:
            raise
        # Both engines were asked for, the Python one has answered: say plainly that this answer
        # has no Alloy proof behind it, rather than refuse to answer.
        engines["alloy"] = {"verdict": "not run", "reason": e.diagnostic.message}
        return Judgement(ev, ev.valid, engines, [e.diagnostic])
    engines["alloy"] = info
    if engine is Engine.BOTH and (valid != ev.valid or failing != python_failing(ev)):
        raise EnginesDisagree(Diagnostic(
            "RC300", Severity.ERROR,
            f"the engines disagree: Python says {'safe' if ev.valid else 'unsafe'}, "
            f"Alloy says {'safe' if valid else 'unsafe'}", system.span,
            notes=(f"Python: unsatisfied {list(python_failing(ev)) or 'none'}",
                   f"Alloy: unsatisfied {list(failing) or 'none'}",
                   "this is a bug in reconf: please report it with the .arch file")))
    return Judgement(ev, valid, engines)


def alloy_judgement(system: System, config: Configuration) -> tuple[bool, Failing, dict[str, Any]]:
    try:
        v = alloy_verdict(system, config, keep=witnesses(system, config, WIDE))
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
    return v.valid, tuple(sorted(v.unsatisfied)), {"verdict": "safe" if v.valid else "unsafe",
                                                    "seconds": round(v.seconds, 4), "method": "evaluation",
                                                    "timing": v.timing(),
                                                    "unsatisfied": [list(x) for x in sorted(v.unsatisfied)]}


def _too_large(e: BaseException) -> bool:
    text = f"{type(e).__name__}: {e}"
    return "capacity exceeded" in text or "OutOfMemoryError" in text


def _first_line(e: BaseException) -> str:
    return (str(e).strip().splitlines() or [type(e).__name__])[0][:160]


def unavailable_diagnostic(e: Exception) -> Optional[Diagnostic]:
    if isinstance(e, (EngineUnavailable, EnginesDisagree)):
        return e.diagnostic
    return None
