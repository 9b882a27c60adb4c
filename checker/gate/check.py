"""The judgement `reconf check` makes of one architecture, and the gate of its head: the two
engines on every assumption (`checker.alloy.engines`), the FTM rules (`checker.ftm.judge`), and,
given one, a recording's rates and types (`checker.reality.recording`)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

from checker.alloy.engines import Engine, Judgement, judge
from checker.ftm.judge import judge_ftm
from checker.reality.recording import RecordingVerdict
from checker.reports import formats, report
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import Evaluation
from reconf_dsl.diagnostics import Diagnostic
from reconf_dsl.ir import System
from reconf_dsl.words import agree, plural


@dataclass
class CheckOutcome:
    system: System
    judged: Judgement
    ftm: list[Diagnostic]                     # the FTM rules' findings (RC4xx)
    ftm_alloy: Optional[dict[str, Any]]       # Alloy's verdict on the FTM rules, when it judged them
    recording: Optional[RecordingVerdict] = None

    @property
    def safe(self) -> bool:
        return (self.judged.valid and not any(d.is_error for d in self.ftm)
                and not (self.recording is not None and self.recording.contradicted))

    @property
    def verdict(self) -> str:
        return "safe" if self.safe else "unsafe"

    @property
    def engines(self) -> dict[str, Any]:
        return self.judged.engines

    @property
    def diagnostics(self) -> list[Diagnostic]:
        """Warnings about the engines, the FTM findings, each assumption that does not hold, and
        what the recording contradicts, in that order."""
        diags = self.judged.warnings + self.ftm + [report.assumption_diagnostic(r)
                                                   for r in self.judged.python.unsatisfied]
        return diags + (self.recording.diagnostics if self.recording else [])

    def cases(self) -> list[formats.CheckCase]:
        """One test case per assumption (and per judged rate or type of the recording)."""
        return (report.assumption_cases(self.system.name, self.judged.python)
                + (self.recording.cases(self.system.name) if self.recording else []))

    def timing_parts(self) -> tuple[list[tuple[str, float]], dict[str, str]]:
        """Where the judgement's time went (after parsing), and what the analyzer's part was made of."""
        parts, details = self.judged.timing()
        if self.ftm_alloy is not None:
            parts.append(("FTM rules in Alloy", self.ftm_alloy["seconds"]))
        if self.recording is not None:
            parts.append(("reading the recording", self.recording.seconds))
        return parts, details

    def line(self, timing: str) -> str:
        """The summary line after the verdict: counts, what holds, by which engines, then `timing`."""
        ev, s = self.judged.python, self.system
        counts = ", ".join(plural(k, w) for k, w in ((len(s.components), "component"),
                                                     (len(s.connectors), "connector"), (len(ev.results), "assumption")))
        bad = len(ev.unsatisfied)
        held = "all hold" if self.judged.valid or not bad else f"{bad} {agree(bad, 'does', 'do')} not hold"
        # the engines' note is about the assumptions; the FTM rules' is said after them
        by = ", judged by Alloy too" if self.ftm_alloy is not None else ""
        ftm_note = (f"; {plural(len(self.ftm), 'fault-tolerance finding')} (FTM rules{by})" if self.ftm else
                    f"; FTM rules hold{by}" if any(c.ftm is not None for c in s.components) else "")
        recorded = "; " + self.recording.summary if self.recording else ""
        return f"{s.name} — {counts}, {held}{self.judged.how()}{ftm_note}{recorded}; {timing}"


def check_system(system: System, engine: Engine = Engine.BOTH,
                 recording: Optional[RecordingVerdict] = None, python: Optional[Evaluation] = None) -> CheckOutcome:
    """Judge `system`'s deployed configuration; raises EngineUnavailable or EnginesDisagree.
    `python`: the Python engine's evaluation of it, when one was made (see `judge`)."""
    judged = judge(system, Configuration.initial(system), engine, python)
    ftm, ftm_alloy = judge_ftm(system, engine)
    if ftm_alloy is not None:
        judged.engines.setdefault("alloy", {})["ftm_rules"] = ftm_alloy
    return CheckOutcome(system, judged, ftm, ftm_alloy, recording)
