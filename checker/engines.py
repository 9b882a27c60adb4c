"""Two engines, one verdict: Alloy proves, the Python engine explains, and they must agree.

A disagreement is an internal error (exit 2) that shows both verdicts: it means the
meta-model, the instance generator or the Python engine is wrong, and no answer is given."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Optional

from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import System
from reconf_dsl.span import Span

from .config import Configuration
from .semantics import Evaluation, evaluate

Failing = tuple[tuple[str, str, int], ...]


class EngineUnavailable(Exception):
    def __init__(self, diagnostic: Diagnostic):
        self.diagnostic = diagnostic


class EnginesDisagree(Exception):
    def __init__(self, diagnostic: Diagnostic):
        self.diagnostic = diagnostic


@dataclass
class Judgement:
    python: Evaluation
    valid: bool
    engines: dict[str, Any] = field(default_factory=dict)

    def how(self) -> str:
        al = self.engines.get("alloy")
        if al is None:
            return " (Python engine)"
        if "python" not in self.engines:
            return f" (Alloy, {al['solver']}, {al['seconds']:.2f} s)"
        return f" (proved by Alloy, {al['solver']}, {al['seconds']:.2f} s; explained by the Python engine)"


def python_failing(ev: Evaluation) -> Failing:
    return tuple(sorted((r.component, r.functionality, r.index) for r in ev.unsatisfied))


def judge(system: System, config: Configuration, engine: str = "both", solver: str = "glucose") -> Judgement:
    started = time.perf_counter()
    ev = evaluate(system, config)
    engines: dict[str, Any] = {}
    if engine in ("both", "python"):
        engines["python"] = {"verdict": "safe" if ev.valid else "unsafe",
                             "seconds": round(time.perf_counter() - started, 4),
                             "unsatisfied": [list(x) for x in python_failing(ev)]}
    if engine == "python":
        return Judgement(ev, ev.valid, engines)
    valid, failing, info = alloy_judgement(system, config, solver)
    engines["alloy"] = info
    if engine == "both" and (valid != ev.valid or failing != python_failing(ev)):
        raise EnginesDisagree(Diagnostic(
            "RC300", Severity.ERROR,
            f"the engines disagree: Python says {'safe' if ev.valid else 'unsafe'}, "
            f"Alloy says {'safe' if valid else 'unsafe'}", system.span,
            notes=(f"Python: unsatisfied {list(python_failing(ev)) or 'none'}",
                   f"Alloy: unsatisfied {list(failing) or 'none'}",
                   "this is a bug in reconf: please report it with the .arch file")))
    return Judgement(ev, valid, engines)


def alloy_judgement(system: System, config: Configuration, solver: str) -> tuple[bool, Failing, dict[str, Any]]:
    from .alloy import AlloyError, AlloyUnavailable, alloy_verdict
    try:
        v = alloy_verdict(system, config, solver=solver)
    except AlloyUnavailable as e:
        raise EngineUnavailable(Diagnostic("RC301", Severity.ERROR, str(e), Span.unknown("<alloy>"),
                                           notes=("or use --engine python",))) from None
    except AlloyError as e:
        raise EngineUnavailable(Diagnostic("RC302", Severity.ERROR, f"Alloy rejected the generated module: {e}",
                                           Span.unknown(e.module or "<alloy>"),
                                           notes=("this is a bug in reconf: please report it",))) from None
    from .alloy.bridge import AlloyBridge
    used = getattr(AlloyBridge.get(), "last_solver", solver)
    return v.valid, tuple(sorted(v.unsatisfied)), {"verdict": "safe" if v.valid else "unsafe",
                                                    "seconds": round(v.seconds, 4), "solver": used,
                                                    "unsatisfied": [list(x) for x in sorted(v.unsatisfied)]}


def unavailable_diagnostic(e: Exception) -> Optional[Diagnostic]:
    if isinstance(e, (EngineUnavailable, EnginesDisagree)):
        return e.diagnostic
    return None
