"""Alloy's verdict on a configuration of a concrete architecture, and on a plan: each
evaluated as an instance (checker.alloy.evaluate)."""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Collection, Iterable, Mapping, Sequence

from checker.alloy.bridge import Backend, get_backend
from checker.alloy.cancel import checkpoint
from checker.alloy.evaluate import Evaluated, Judging, evaluator, judging_threads
from checker.alloy.jvm import usable
from checker.semantic_model.actions import KINDS, Action
from checker.semantic_model.config import Configuration
from codegen.alloy import PLAN_EVALUATION_SIGS, describe_instance_data, describe_plan_data, slice_index
from codegen.alloy_module import InstanceData, Meaning
from codegen.alloy_xml import instance_xml
from reconf_dsl.ir import Component, Predicate, System

PLAN_MODULE = "plan_evaluate.als"

# Components judged per instance: a large architecture is judged as a partition of slices
# of about this many components each (describe_instance_data with `focus`); validity is
# local, so the configuration is valid exactly when every slice is. Reading an instance and
# evaluating in it grow faster than its atoms (the evaluator's matrices are indexed by the
# universe) while a slice's fixed cost is small (docs/soundness.md, "Slicing a large check").
SLICE = 64


@dataclass(frozen=True)
class AlloyVerdict:
    """`valid` as Alloy judges it; `unsatisfied` lists (component, functionality,
    assumption index) of every assumption that does not hold, sorted. `texts` are the
    instances the analyzer read (instance XML of the evaluation module): the whole
    architecture, or one slice each."""

    valid: bool
    unsatisfied: tuple[tuple[str, str, int], ...]
    seconds: float
    texts: tuple[str, ...]
    # Where the caller's time went while it waited for this verdict (see `PendingVerdict`):
    # writing the instances, then waiting for the analyzer's start (the JVM, and parsing the
    # evaluation module, once per process) and for the instances still being judged. The
    # analyzer's threads judge alongside the writing: `read_seconds` (reading the instances)
    # and `seconds` (evaluating in them) are those threads' time, summed.
    start_seconds: float = 0.0
    render_seconds: float = 0.0
    read_seconds: float = 0.0
    judging_seconds: float = 0.0
    threads: int = 1

    def timing(self) -> dict[str, float]:
        return {"start": round(self.start_seconds, 4), "render": round(self.render_seconds, 4),
                "judging": round(self.judging_seconds, 4), "instances": len(self.texts),
                "read": round(self.read_seconds, 4), "evaluate": round(self.seconds, 4), "threads": self.threads}

    @property
    def text(self) -> str:
        """The instances read, one after another."""
        return "\n".join(self.texts)


def slices(system: System, config: Configuration, size: int = SLICE, only: Iterable[str] | None = None) -> list[set[str]] | None:
    """A partition of the present components (of those in `only`, if given) into slices of
    `size` in declaration order (neighbours in the file tend to read each other), or None
    when one instance of the whole architecture will do."""
    judged = config.components if only is None else config.components & set(only)
    present = [c.name for c in system.components if c.name in judged]
    present += sorted(judged - set(present))
    if len(present) <= size and only is None:
        return None
    return [set(present[i:i + size]) for i in range(0, len(present), size)]


def alloy_verdict(system: System, config: Configuration, bridge: Backend | None = None,
                  slice_size: int = SLICE, only: Iterable[str] | None = None,
                  keep: Mapping[str, Collection[tuple[str, str]]] | None = None) -> AlloyVerdict:
    """Judge `config` (checker.semantic_model.config.Configuration) of `system` (reconf_dsl.ir.System)
    in Alloy: `valid` of the shared semantics evaluated in each slice as an instance
    (checker.alloy.evaluate). With `only` (a set of component names), judge the assumptions
    of those components alone. `keep` (checker.semantic_model.semantics.witnesses) lets a slice show a
    wide connector's witness alone; a slice that is not valid so is judged again with every
    publisher."""
    return PendingVerdict(system, config, bridge, slice_size, only, keep).result()


class PendingVerdict:
    """`alloy_verdict` in two halves, so that the caller works while the analyzer judges: made,
    it writes every instance and hands each to the analyzer's threads (`evaluate.Judging`) as
    soon as it is written; `result()` waits for the verdict. Whatever the caller does in
    between (the Python engine) runs alongside the judging. `result()` or `close()` must be
    called (the threads end there)."""

    def __init__(self, system: System, config: Configuration, bridge: Backend | None = None,
                 slice_size: int = SLICE, only: Iterable[str] | None = None,
                 keep: Mapping[str, Collection[tuple[str, str]]] | None = None) -> None:
        clock = time.perf_counter()
        if bridge is None:
            usable()               # no Java, no jar: said now, before any instance is written
        self.system, self.config, self.keep = system, config, keep
        parts = slices(system, config, slice_size, only)
        self.focuses: list[set[str] | None] = list(parts) if parts else [None]
        self.index = slice_index(system, config) if parts else None
        self.lean = bool(keep) and parts is not None       # each slice first with a wide connector's witness alone
        self.judging = Judging(bridge, judging_threads(len(self.focuses)))
        self.texts: list[str] = []
        self.names: list[Mapping[str, Meaning]] = []
        try:
            for i, focus in enumerate(self.focuses):
                checkpoint()    # a caller inside checker.alloy.cancel.cancellable may stop here
                self._write(i, focus, self.lean)
        except BaseException:
            self.judging.close()
            raise
        self.render = time.perf_counter() - clock

    def _write(self, i: int, focus: set[str] | None, lean: bool) -> None:
        data = describe_instance_data(self.system, self.config, focus, self.index, self.keep if lean else None)
        xml = instance_xml(data)
        if i < len(self.texts):
            self.texts[i], self.names[i] = xml, data.names
        else:
            self.texts.append(xml)
            self.names.append(data.names)
        self.judging.put((i, lean), xml)

    def close(self) -> None:
        self.judging.close()

    def result(self) -> AlloyVerdict:
        """The verdict, once every instance is judged (a lean slice that is not valid is
        written and judged again with every publisher)."""
        try:
            began = time.perf_counter()
            verdicts = self.judging.wait([(i, self.lean) for i in range(len(self.focuses))])
            first = time.perf_counter()
            again = [i for i in range(len(self.focuses)) if self.lean and not verdicts[i, True].valid]
            for i in again:
                checkpoint()
                self._write(i, self.focuses[i], False)
            written = time.perf_counter()
            verdicts.update(self.judging.wait([(i, False) for i in again]))
        finally:
            self.judging.close()
        self.render += written - first
        waited = (first - began) + (time.perf_counter() - written)
        ready = self.judging.ready if self.judging.ready is not None else began
        start = max(0.0, min(ready, first) - began)      # of the wait, before the analyzer was ready
        return self._verdict(verdicts, again, start, waited - start)

    def _verdict(self, verdicts: Mapping[Any, Evaluated], again: list[int], start: float,
                 judging: float) -> AlloyVerdict:
        """The verdict of the instances judged; reading which assumptions fail off them counts
        in `judging`."""
        clock = time.perf_counter()
        failing: set[tuple[str, str, int]] = set()
        components: dict[str, Component] = {}
        for c in self.system.components + self.system.versions:
            components.setdefault(c.name, c)         # the first of a name, as System.component finds it
        for i in range(len(self.focuses)):
            last = verdicts[i, self.lean and i not in again]
            if not last.valid:
                failing |= _failing(self.system, last.unsatisfied, self.names[i], components) or {("", "", -1)}
        judged = verdicts.values()
        judging += time.perf_counter() - clock
        return AlloyVerdict(not failing, tuple(sorted(failing)), sum(v.evaluate for v in judged), tuple(self.texts),
                            start, self.render, sum(v.read for v in judged), judging, self.judging.threads)


def _failing(system: System, pairs: Iterable[tuple[str, str]], names: Mapping[str, Meaning],
             components: Mapping[str, Component] | None = None) -> set[tuple[str, str, int]]:
    """Each (functionality atom, datum atom) that does not hold, as (component,
    functionality, assumption index) of every assumption of that datum. `components`: the
    system's by name, when the caller has them."""
    atoms = {meaning: atom for atom, meaning in names.items()}
    failing: set[tuple[str, str, int]] = set()
    for f_atom, d_atom in pairs:
        _, comp, func = names[f_atom]
        component = components.get(comp) if components is not None else system.component(comp)
        assert component is not None, "the instance's components are the system's"
        functionality = next(f for f in component.functionalities if f.name == func)
        assert functionality.normal is not None, "resolved IR has both modes"
        for index, a in enumerate(functionality.normal.assumptions):
            if _datum_atom(a, atoms) == d_atom:
                failing.add((comp, func, index))
    return failing


def _datum_atom(pred: Predicate, atoms: Mapping[Meaning, str]) -> str:
    """The atom of an assumption's datum (codegen.alloy._Data)."""
    if pred.message is None:
        return "Nothing"
    return atoms.get(("data", pred.message, "" if pred.hz is None else str(pred.hz)), "")


def _planned_actions(data: InstanceData) -> list[tuple[str, ...]]:
    """Per step of a plan's instance, the action the difference between its two
    configurations is (empty where it is not one action), as the instance says it
    (`<action>_steps`): what a plan Alloy found safe performs."""
    kind_of_step = {t: k.name for k in KINDS for t in data.atoms.get(f"{k.name}_steps", ())}
    return [(kind_of_step[t],) if t in kind_of_step else () for t in data.atoms["Step"]]


@dataclass(frozen=True)
class AlloyPlanVerdict:
    """Alloy's judgement of a plan: `valid[i]` for each configuration, and for each step i
    (configuration i to i+1) the action it performs when that action's pre/post-conditions
    hold (empty when they do not, or when the step is not a single action)."""

    valid: tuple[bool, ...]
    steps: tuple[tuple[str, ...], ...]
    seconds: float
    text: str
    # per configuration: no request lost (every `serving` proxy normal, connector satisfied);
    # all True when the plan names nothing to keep serving
    lossless: tuple[bool, ...] = ()
    # per configuration: every `stable` connector satisfied (all True when none is named)
    stable: tuple[bool, ...] = ()
    # per configuration: well formed (one publisher on a `single` topic, one server on a
    # service, every attachment typed and of a present component)
    formed: tuple[bool, ...] = ()

    @property
    def ok(self) -> bool:
        return all(self.valid) and all(self.formed) and all(self.steps) and all(self.lossless) and all(self.stable)


def alloy_plan_verdict(system: System, configs: Sequence[Configuration], bridge: Backend | None = None,
                       serving: Iterable[tuple[str, str]] = (), stable: Iterable[str] = (),
                       protocols: Iterable[tuple[str, str]] = (),
                       handover: Iterable[tuple[str, str]] = (),
                       actions: Sequence[Action | None] | None = None) -> AlloyPlanVerdict:
    """Judge a plan (its successive configurations, initial first) in Alloy, by evaluating
    the plan evaluation module's `plan_safe` in it as an instance (checker.alloy.evaluate):
    each configuration valid, each step one of the six actions with its preconditions met,
    and, with `serving` ((connector, proxy) pairs), each configuration lossless (with
    `protocols`, each proxy's requests reaching one of them; with `handover` ((connector,
    proxy) pairs of servers losing their FTM), each such proxy normal with its requests
    reaching a protocol while it still publishes on the connector), and with `stable`
    (connector names), each configuration satisfying them. Each configuration must be well
    formed too. With `actions` (one per step), each step is judged as the action the plan
    says it is; without, as the one action the difference between its configurations is.
    `text` is the instance read."""
    data = describe_plan_data(system, configs, list(serving), list(stable), list(protocols), list(handover),
                              actions)
    text = instance_xml(data, PLAN_EVALUATION_SIGS)
    judge = evaluator(bridge or get_backend(), PLAN_MODULE)
    clock = time.perf_counter()
    instance = judge.read(text)
    n = len(configs)
    if instance.holds("plan_safe"):
        every = tuple(True for _ in range(n))
        return AlloyPlanVerdict(every, tuple(_planned_actions(data)), time.perf_counter() - clock,
                                text, every, every, every)
    states = [f"S{i}" for i in range(n)]

    def per_state(expr: str) -> tuple[bool, ...]:
        holding = {s for (s,) in instance.value(expr)}
        return tuple(s in holding for s in states)

    ok = {t for (t,) in instance.value("ok_steps")}
    steps = tuple(action if f"t{i}" in ok else () for i, action in enumerate(_planned_actions(data)))
    return AlloyPlanVerdict(per_state("valid_states"), steps, time.perf_counter() - clock, text,
                            per_state("lossless_states"), per_state("stable_states"), per_state("formed_states"))
