"""The FTM rules judged by both engines: the Python engine's diagnostics, and Alloy's verdict on
the same rules (alloy_model/ftm.als), which must agree with them."""
from __future__ import annotations

from typing import Any, Optional

from checker.alloy import AlloyError, AlloyUnavailable
from checker.alloy.engines import Engine, EnginesDisagree, EngineUnavailable
from checker.ftm.alloy_rules import alloy_ftm_verdict
from checker.ftm.diagnose import ftm_findings, in_order
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import System
from reconf_dsl.span import Span


def judge_ftm(system: System, engine: Engine = Engine.BOTH) -> tuple[list[Diagnostic], Optional[dict[str, Any]]]:
    """The FTM rules (RC401–RC407) on every component with an FTM: the Python engine's
    diagnostics and, when `engine` has Alloy judge, Alloy's judgement of the same rules
    (alloy_model/ftm.als: which attached FTMs contradict (F, A, R), which are written in the
    wrong order, which duplexes lack two hosts), which must agree with them."""
    findings = ftm_findings(system)
    diags = in_order(d for _, d in findings)
    if not engine.alloy or not any(c.ftm is not None for c in system.components):
        return diags, None
    try:
        v = alloy_ftm_verdict(system)
    except AlloyUnavailable as e:
        raise EngineUnavailable(Diagnostic("RC301", Severity.ERROR, str(e), Span.unknown("<alloy>"),
                                           notes=("or use --engine python",))) from None
    except AlloyError as e:
        raise EngineUnavailable(Diagnostic(
            "RC302", Severity.ERROR, f"Alloy rejected the generated FTM module: {e}", Span.unknown("<alloy>"),
            notes=("this is a bug in reconf: please report it",))) from None

    def python(*codes: str) -> list[str]:
        return sorted({c for c, d in findings if d.code in codes})

    ours = {"contradicted": python("RC402", "RC403", "RC404", "RC405"), "misnested": python("RC401"),
            "hostless": python("RC406")}
    theirs = {"contradicted": sorted(v.contradicted), "misnested": sorted(v.misnested),
              "hostless": sorted(v.hostless)}
    if ours != theirs:
        raise EnginesDisagree(Diagnostic(
            "RC300", Severity.ERROR, "the engines disagree on the FTM rules", system.span,
            notes=(f"Python: {ours}", f"Alloy: {theirs}",
                   "this is a bug in reconf: please report it with the .arch file")))
    return diags, dict(theirs, seconds=round(v.seconds, 4))
