"""Judging by evaluation: the analyzer reads a configuration (or a plan's configurations) as
an instance of an evaluation module (`codegen.alloy.render_evaluation_module`,
`render_plan_evaluation_module`, each parsed once per process) and evaluates the shared
semantics in it (docs/soundness.md, "Judging by evaluation").

A configuration is fully given: every relation's value is known, so checking `valid` of it is
evaluating `valid` in it. The analyzer's own instance reader (A4SolutionReader, the reader
of the instances it saves) builds the instance, and its evaluator (Kodkod's) evaluates the
module's definitions over it; there is nothing to solve, and no module text per instance.
"""
from __future__ import annotations

import threading
import time
from typing import Any, Callable, NamedTuple

from checker.alloy.bridge import Backend, get_backend
from checker.alloy.errors import AlloyError
from codegen.alloy import render_evaluation_module, render_plan_evaluation_module

Tuples = tuple[tuple[str, ...], ...]


class Evaluated(NamedTuple):
    valid: bool
    unsatisfied: tuple[tuple[str, str], ...]    # (functionality atom, data atom), when not valid
    read: float                                 # seconds reading the instance
    evaluate: float                             # seconds evaluating in it


class Instance:
    """An instance the analyzer read, and what is evaluated in it."""

    def __init__(self, evaluator: "Evaluator", solution: Any) -> None:
        self._evaluator, self._solution = evaluator, solution

    def holds(self, pred: str) -> bool:
        """Whether the formula `pred` (one of the evaluator's expressions) holds."""
        with self._evaluator.lock:
            return bool(self._solution.eval(self._evaluator.expr(pred)))

    def value(self, expr: str) -> Tuples:
        """The value of `expr` (one of the evaluator's expressions): tuples of the instance's
        own atoms (the analyzer shows them renamed, Sig$0, in its own tuples)."""
        with self._evaluator.lock:
            tuples = self._solution.eval(self._evaluator.expr(expr)).debugGetKodkodTupleset()
            return tuple(sorted(tuple(str(t.atom(i)) for i in range(t.arity())) for t in tuples))


class Evaluator:
    """An evaluation module parsed by one bridge, its expressions `exprs`, and instances of it."""

    def __init__(self, bridge: Backend, main: str, text: str, exprs: tuple[str, ...]) -> None:
        from edu.mit.csail.sdg.alloy4 import A4Reporter, Err  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.parser import CompUtil  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.translator import A4SolutionReader  # type: ignore[import-not-found]

        self.main, self.lock = main, bridge.lock
        self._Err, self._reader = Err, A4SolutionReader
        try:
            module = CompUtil.parseEverything_fromString(A4Reporter(), text)
            self._sigs = module.getAllReachableSigs()
            self._exprs = {e: CompUtil.parseOneExpression_fromString(module, e) for e in exprs}
        except Err as err:
            raise AlloyError(f"{main}: {err.msg}", main, int(err.pos.y), int(err.pos.x)) from None

    def expr(self, name: str) -> Any:
        return self._exprs[name]

    def read(self, xml: str) -> Instance:
        """The instance `xml` (codegen.alloy_xml.instance_xml) as the analyzer reads it."""
        from edu.mit.csail.sdg.alloy4 import XMLNode  # type: ignore[import-not-found]
        from java.io import StringReader  # type: ignore[import-not-found]

        with self.lock:
            try:
                return Instance(self, self._reader.read(self._sigs, XMLNode(StringReader(xml))))
            except self._Err as err:
                raise AlloyError(f"the analyzer could not read an instance of {self.main}: {err.msg}",
                                 self.main) from None

    def judge(self, xml: str) -> Evaluated:
        """`valid` and `well_formed` in the configuration `xml`, and when it is not valid, which
        assumptions fail (an ill-formed configuration with every assumption holding is not
        valid either, with none failing)."""
        clock = time.perf_counter()
        instance = self.read(xml)
        read = time.perf_counter() - clock
        clock = time.perf_counter()
        valid = instance.holds(JUDGED)
        failing = () if valid else tuple((f, d) for f, d in instance.value("unsatisfied"))
        return Evaluated(valid, failing, read, time.perf_counter() - clock)


# what a configuration must be, evaluated as one formula (one pass of the evaluator)
JUDGED = "valid and well_formed"
_MODULES: dict[str, tuple[Callable[[], str], tuple[str, ...]]] = {
    "evaluate.als": (render_evaluation_module, (JUDGED, "unsatisfied")),
    "plan_evaluate.als": (render_plan_evaluation_module,
                          ("plan_safe", "valid_states", "formed_states", "ok_steps", "lossless_states",
                           "stable_states")),
}
_evaluators: dict[tuple[int, str], Evaluator] = {}
_lock = threading.Lock()


def evaluator(bridge: Backend, main: str = "evaluate.als") -> Evaluator:
    """The bridge's evaluator of the evaluation module `main` (evaluate.als, a configuration;
    plan_evaluate.als, a plan), parsing the module on first use."""
    with _lock:
        found = _evaluators.get((id(bridge), main))
        if found is None:
            render, exprs = _MODULES[main]
            found = _evaluators[id(bridge), main] = Evaluator(bridge, main, render(), exprs)
        return found


def forget() -> None:
    """Render and parse the evaluation modules again on their next use (for a test that
    renders them from other templates)."""
    with _lock:
        _evaluators.clear()
    render_evaluation_module.cache_clear()
    render_plan_evaluation_module.cache_clear()


_early: list[threading.Thread] = []


def start_early() -> None:
    """Start the analyzer and parse the evaluation module on a thread of their own, while
    this one goes on (a check parses its files meanwhile). Whoever needs the analyzer next
    waits for it there; an error here is raised again there (the start is tried again)."""
    if _early:
        return

    def start() -> None:
        try:
            evaluator(get_backend())
        except Exception:  # noqa: BLE001 - the next get_backend() raises it, in its place
            return
        # A thread the JVM knows as a user thread holds the JVM's shutdown at exit until it
        # is detached, and this one ends here: detached, the process ends when it is done.
        from java.lang import Thread  # type: ignore[import-not-found]

        Thread.detach()

    # not a daemon: a process that ends before the start is done (a file that does not parse)
    # waits for it before its exit handlers run, the JVM's shutdown among them
    thread = threading.Thread(target=start, name="reconf-alloy-start", daemon=False)
    _early.append(thread)
    thread.start()
