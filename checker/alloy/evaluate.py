"""Judging a configuration by evaluation: the analyzer reads it as an instance of the
evaluation module (`codegen.alloy.render_evaluation_module`, parsed once per process) and
evaluates the shared semantics' `valid` in it (docs/soundness.md, "Judging a configuration").

A configuration is fully given: every relation's value is known, so checking `valid` of it is
evaluating `valid` in it. The analyzer's own instance reader (A4SolutionReader, the reader
of the instances it saves) builds the instance, and its evaluator (Kodkod's) evaluates the
module's definitions over it; there is nothing to solve, and no module text per configuration.
"""
from __future__ import annotations

import threading
import time
from typing import NamedTuple

from checker.alloy.bridge import AlloyBridge
from checker.alloy.errors import AlloyError
from codegen.alloy import render_evaluation_module

MODULE = "evaluate.als"


class Evaluated(NamedTuple):
    valid: bool
    unsatisfied: tuple[tuple[str, str], ...]    # (functionality atom, data atom), when not valid
    read: float                                 # seconds reading the instance
    evaluate: float                             # seconds evaluating in it


class Evaluator:
    """The evaluation module parsed by one bridge, and what is evaluated in its instances."""

    def __init__(self, bridge: AlloyBridge) -> None:
        from edu.mit.csail.sdg.alloy4 import A4Reporter, Err  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.parser import CompUtil  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.translator import A4SolutionReader  # type: ignore[import-not-found]

        clock = time.perf_counter()
        self._Err = Err
        self._reader = A4SolutionReader
        try:
            module = CompUtil.parseEverything_fromString(A4Reporter(), render_evaluation_module())
            self._sigs = module.getAllReachableSigs()
            self._valid = CompUtil.parseOneExpression_fromString(module, "valid")
            self._unsatisfied = CompUtil.parseOneExpression_fromString(module, "unsatisfied")
        except Err as err:
            raise AlloyError(f"the evaluation module: {err.msg}", MODULE, int(err.pos.y), int(err.pos.x)) from None
        self.parse_seconds = time.perf_counter() - clock
        self._lock = bridge._lock

    def judge(self, xml: str) -> Evaluated:
        """`valid` in the instance `xml` (codegen.alloy_xml.instance_xml), and when it does
        not hold, which assumptions fail."""
        from edu.mit.csail.sdg.alloy4 import XMLNode  # type: ignore[import-not-found]
        from java.io import StringReader  # type: ignore[import-not-found]

        with self._lock:
            clock = time.perf_counter()
            try:
                solution = self._reader.read(self._sigs, XMLNode(StringReader(xml)))
            except self._Err as err:
                raise AlloyError(f"the analyzer could not read an instance: {err.msg}", MODULE) from None
            read = time.perf_counter() - clock
            clock = time.perf_counter()
            valid = bool(solution.eval(self._valid))
            failing: tuple[tuple[str, str], ...] = ()
            if not valid:
                # the instance's own atoms: the analyzer's tuples show them renamed (Sig$0)
                tuples = solution.eval(self._unsatisfied).debugGetKodkodTupleset()
                failing = tuple(sorted((str(t.atom(0)), str(t.atom(1))) for t in tuples))
            return Evaluated(valid, failing, read, time.perf_counter() - clock)


_evaluators: dict[int, Evaluator] = {}
_lock = threading.Lock()


def evaluator(bridge: AlloyBridge) -> Evaluator:
    """The bridge's evaluator, parsing the evaluation module on first use."""
    with _lock:
        found = _evaluators.get(id(bridge))
        if found is None:
            found = _evaluators[id(bridge)] = Evaluator(bridge)
        return found
