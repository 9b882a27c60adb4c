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

import os
import queue
import threading
import time
from contextlib import nullcontext
from typing import Any, Callable, Hashable, NamedTuple, Optional

from checker.alloy.bridge import Backend, get_backend
from checker.alloy.cancel import Cancelled, current_test
from checker.alloy.errors import AlloyError
from checker.alloy.jvm import detach_thread, java_class
from codegen.alloy import render_evaluation_module, render_plan_evaluation_module
from codegen.alloy_module import InstanceData
from codegen.alloy_xml import instance_xml

Tuples = tuple[tuple[str, ...], ...]


class Evaluated(NamedTuple):
    valid: bool
    unsatisfied: tuple[tuple[str, str], ...]    # (functionality atom, data atom), when not valid
    read: float                                 # seconds reading the instance
    evaluate: float                             # seconds evaluating in it


class Instance:
    """An instance the analyzer read, and what is evaluated in it."""

    def __init__(self, evaluator: "Evaluator", solution: Any, locked: bool = True) -> None:
        self._evaluator, self._solution = evaluator, solution
        self._lock = evaluator.lock if locked else nullcontext()

    def holds(self, pred: str) -> bool:
        """Whether the formula `pred` (one of the evaluator's expressions) holds."""
        with self._lock:
            return bool(self._solution.eval(self._evaluator.expr(pred)))

    def value(self, expr: str) -> Tuples:
        """The value of `expr` (one of the evaluator's expressions): tuples of the instance's
        own atoms (the analyzer shows them renamed, Sig$0, in its own tuples)."""
        with self._lock:
            tuples = self._solution.eval(self._evaluator.expr(expr)).debugGetKodkodTupleset()
            return tuple(sorted(tuple(str(t.atom(i)) for i in range(t.arity())) for t in tuples))


class Evaluator:
    """An evaluation module parsed by one bridge, its expressions `exprs`, and instances of it.

    `read` and `judge` hold the bridge's lock, as everything the analyzer does in this process
    does, unless `locked=False`: reading an instance and evaluating in it share nothing with
    other work of the analyzer but the parsed module, which they only read (A4SolutionReader
    finds the module's sigs and fields among those given and makes a solution of its own;
    the evaluator translates the expression for that solution alone), so `Judging` runs them
    on several threads at once."""

    def __init__(self, bridge: Backend, main: str, text: str, exprs: tuple[str, ...]) -> None:
        comp_util = java_class("edu.mit.csail.sdg.parser.CompUtil")
        self.main, self.lock = main, bridge.lock
        self._Err = java_class("edu.mit.csail.sdg.alloy4.Err")
        self._reader = java_class("edu.mit.csail.sdg.translator.A4SolutionReader")
        self._xml = java_class("edu.mit.csail.sdg.alloy4.XMLNode")
        self._text = java_class("java.io.StringReader")
        try:
            module = comp_util.parseEverything_fromString(java_class("edu.mit.csail.sdg.alloy4.A4Reporter")(), text)
            self._sigs = module.getAllReachableSigs()
            self._exprs = {e: comp_util.parseOneExpression_fromString(module, e) for e in exprs}
        except self._Err as err:
            raise AlloyError(f"{main}: {err.msg}", main, int(err.pos.y), int(err.pos.x)) from None

    def expr(self, name: str) -> Any:
        return self._exprs[name]

    def read(self, xml: str, locked: bool = True) -> Instance:
        """The instance `xml` (codegen.alloy_xml.instance_xml) as the analyzer reads it."""
        with self.lock if locked else nullcontext():
            try:
                return Instance(self, self._reader.read(self._sigs, self._xml(self._text(xml))), locked)
            except self._Err as err:
                raise AlloyError(f"the analyzer could not read an instance of {self.main}: {err.msg}",
                                 self.main) from None

    def judge(self, xml: str, locked: bool = True) -> Evaluated:
        """`valid` and `well_formed` in the configuration `xml`, and when it is not valid, which
        assumptions fail (an ill-formed configuration with every assumption holding is not
        valid either, with none failing)."""
        clock = time.perf_counter()
        instance = self.read(xml, locked)
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


def prepare(bridge: Backend) -> None:
    """Parse the evaluation module and judge an empty configuration in it, so that the analyzer
    has loaded, and run once, the code every instance needs before the first one comes (in a
    cold JVM that first instance took 0.16-0.2 s, the next ones 0.04 s). For a thread that
    starts the analyzer while the caller has no instance to give it yet."""
    evaluator(bridge).judge(instance_xml(InstanceData("", {}, {}, {})))


_early: list[threading.Thread] = []


def start_early() -> None:
    """Start the analyzer and parse the evaluation module on a thread of their own, while
    this one goes on (a check parses its files meanwhile). Whoever needs the analyzer next
    waits for it there; an error here is raised again there (the start is tried again)."""
    if _early:
        return

    def start() -> None:
        try:
            prepare(get_backend())
        except Exception:  # noqa: BLE001 - the next get_backend() raises it, in its place
            return
        detach_thread()       # this thread ends here: see jvm.detach_thread

    # not a daemon: a process that ends before the start is done (a file that does not parse)
    # waits for it before its exit handlers run, the JVM's shutdown among them
    thread = threading.Thread(target=start, name="reconf-alloy-start", daemon=False)
    _early.append(thread)
    thread.start()


THREADS_ENV = "RECONF_ALLOY_THREADS"


def judging_threads(instances: int) -> int:
    """How many threads judge `instances` instances: $RECONF_ALLOY_THREADS, else two on a
    machine of two cores or more (measured: 16 instances of a cold 1,000-component check,
    0.57 s on one thread, 0.40 s on two, load 2; a third gains nothing on two cores), never
    more than the instances."""
    given = os.environ.get(THREADS_ENV, "").strip()
    wanted = int(given) if given.isdigit() and int(given) > 0 else min(2, os.cpu_count() or 1)
    return max(1, min(wanted, instances))


class Judging:
    """Instances of the evaluation module judged on `threads` threads of their own while the
    caller goes on (renders the next ones, runs the Python engine): `put` hands one over,
    `wait` returns the verdicts. The threads wait for the analyzer's start if it is not done;
    `ready` is when it was (perf_counter). Inside `checker.alloy.cancel.cancellable`, the
    threads stop between instances once the judgement is cancelled, and `put` and `wait`
    raise Cancelled. An error of the analyzer is raised by the next `put` or `wait`."""

    def __init__(self, bridge: Optional[Backend], threads: int) -> None:
        self._bridge = bridge
        self._todo: "queue.Queue[Optional[tuple[Hashable, str]]]" = queue.Queue()
        self._done: dict[Hashable, Evaluated] = {}
        self._changed = threading.Condition()
        self._errors: list[BaseException] = []
        self._cancelled = current_test()
        self._closed = False
        self.ready: Optional[float] = None
        self.threads = threads
        self._workers = [threading.Thread(target=self._work, name=f"reconf-alloy-judge-{i}", daemon=True)
                         for i in range(threads)]
        for w in self._workers:
            w.start()

    def _work(self) -> None:
        try:
            judge = evaluator(self._bridge or get_backend())
            with self._changed:
                self.ready = self.ready or time.perf_counter()
            while (item := self._todo.get()) is not None and not self._errors and not self._closed:
                if self._cancelled is not None and self._cancelled():
                    raise Cancelled()
                verdict = judge.judge(item[1], locked=False)
                with self._changed:
                    self._done[item[0]] = verdict
                    self._changed.notify_all()
        except BaseException as err:  # noqa: BLE001 - raised again by put or wait, in the caller's thread
            with self._changed:
                self._errors.append(err)
                self._changed.notify_all()
        finally:
            self._detach()

    @staticmethod
    def _detach() -> None:
        try:
            detach_thread()
        except Exception:  # noqa: BLE001 - no JVM (it could not start): nothing to detach
            pass

    def _raise(self) -> None:
        if self._errors:
            self.close()
            raise self._errors[0]

    def put(self, key: Hashable, xml: str) -> None:
        """Judge the instance `xml`, known as `key`."""
        self._raise()
        self._todo.put((key, xml))

    def wait(self, keys: list[Hashable]) -> dict[Hashable, Evaluated]:
        """The verdicts of `keys` (each `put` before), once they are all judged."""
        with self._changed:
            while not self._errors and any(k not in self._done for k in keys):
                self._changed.wait(0.5)
        self._raise()
        return {k: self._done[k] for k in keys}

    def close(self) -> None:
        """Let the threads end, each after the instance it judges (those not judged yet are
        not: the caller has what it waited for, or gave up)."""
        if not self._closed:
            self._closed = True
            for _ in self._workers:
                self._todo.put(None)
