"""How long each action takes on the wire, and how long a plan keeps what served degraded.

An action's duration, in order of precedence (docs/soundness.md#seconds-on-the-wire):

1. what a run report timed for that action on that component (`Durations.observed`: the
   median of the steps the executor confirmed);
2. the component's `takes` line in the `.arch` (`takes create 2.5 s`);
3. what a run report timed for that action on any component;
4. the measured default of the action's kind (`checker.semantic_model.actions.KINDS`,
   `ActionKind.seconds`: medians of the executor's step reports in `bench_live`).

Degraded seconds (`degraded_seconds`): a step takes effect when the executor has confirmed it
on the wire, at its end, so while step i runs the system is in the state before it. Each
functionality that is degraded in that state, of a component that served before the plan
(present in its first state) and is still there after the step, is degraded for the step's
duration. The steps of a batch (checker.planning.batches) all begin at the batch's start and
each takes effect at its own end; the next step begins after the slowest. A component the plan creates served no one before: its degraded modes until its
first upgrade cost nothing, which is why creating it before anyone degrades is free. Summed
per functionality, and over functionalities weighted by criticality: the plan's degraded
functionality-seconds, the quantity the timeline of a run measures step by step
(checker.reports.timeline) and the default strategy's order minimises
(checker.planning.prepare).
"""
from __future__ import annotations

import statistics
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from checker.semantic_model.actions import KINDS, Action, catalogue
from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.ir import System

__all__ = ["Durations", "Degradation", "durations", "degraded_seconds", "most_first", "schedule"]


@dataclass(frozen=True)
class Durations:
    """Seconds per action: by kind, by (component, kind), and where they came from."""

    kinds: Mapping[str, float]
    components: Mapping[tuple[str, str], float] = field(default_factory=dict)
    sources: tuple[str, ...] = ("measured defaults",)

    def of(self, action: Action) -> float:
        return self.components.get((action.component, action.kind), self.kinds[action.kind])

    def observed(self, report: Mapping[str, Any], where: str) -> "Durations":
        """These durations, overridden by the medians a run report timed (its `timings`, each
        step named by the plan document it carries): per (component, action) and per action."""
        steps = ((report.get("plan_document") or {}).get("plan") or {}).get("steps") or []
        per_kind: dict[str, list[float]] = {}
        per_comp: dict[tuple[str, str], list[float]] = {}
        for t in report.get("timings") or []:
            i = t.get("step", 0) - 1
            if not t.get("ok") or not 0 <= i < len(steps) or steps[i].get("action") not in self.kinds:
                continue
            kind, comp = steps[i]["action"], steps[i].get("component", "")
            per_kind.setdefault(kind, []).append(float(t["seconds"]))
            per_comp.setdefault((comp, kind), []).append(float(t["seconds"]))
        if not per_kind:
            return self
        kinds = {**self.kinds, **{k: statistics.median(v) for k, v in per_kind.items()}}
        comps = {**self.components, **{k: statistics.median(v) for k, v in per_comp.items()}}
        return Durations(kinds, comps, self.sources + (f"{where} ({sum(map(len, per_kind.values()))} steps timed)",))

    def to_dict(self) -> dict[str, Any]:
        return {"kinds": dict(self.kinds), "sources": list(self.sources),
                "components": [{"component": c, "action": k, "seconds": s}
                               for (c, k), s in sorted(self.components.items())]}


def durations(system: System) -> Durations:
    """The measured defaults, with the `takes` lines of `system`'s components over them."""
    comps = {(c.name, t.action): float(t.seconds) for c in system.components + system.versions for t in c.takes}
    sources = ("measured defaults",) + (("the architecture's `takes` lines",) if comps else ())
    return Durations({k.name: k.seconds for k in KINDS}, comps, sources)


def most_first(seconds: Mapping[str, float], shown: int = 3, digits: int = 2) -> str:
    """The `shown` names with the most seconds, most first (then by name), each with its seconds."""
    ranked = sorted(seconds.items(), key=lambda kv: (-kv[1], kv[0]))
    return ", ".join(f"{k} {s:.{digits}f} s" for k, s in ranked[:shown]) + (", …" if len(ranked) > shown else "")


@dataclass(frozen=True)
class Degradation:
    """A plan's expected time on the wire: `total` s of steps, and per functionality that
    served before the plan the seconds it spends degraded; `weighted` is their sum weighted by
    criticality (the quantity minimised)."""

    total: float
    seconds: Mapping[FuncId, float]
    weighted: float

    def longest(self, shown: int = 3) -> str:
        """The `shown` functionalities degraded longest, most first, with their seconds."""
        return most_first({f"{c}.{f}": s for (c, f), s in self.seconds.items()}, shown)

    def to_dict(self) -> dict[str, Any]:
        return {"plan": round(self.total, 3), "weighted": round(self.weighted, 3),
                "functionalities": [{"component": c, "functionality": f, "seconds": round(s, 3)}
                                    for (c, f), s in sorted(self.seconds.items())]}


def schedule(steps: Sequence[Action], times: Durations,
             batches: Sequence[tuple[int, int]] = ()) -> tuple[list[tuple[float, float]], float]:
    """When each step begins and ends, and when the last ends: one after the other, and the
    steps of a batch (first and last step, from 1) all at the batch's start, the next step
    after the batch's slowest."""
    firsts = {a - 1: b for a, b in batches}
    out: list[tuple[float, float]] = []
    clock, i = 0.0, 0
    while i < len(steps):
        last = firsts.get(i, i + 1)
        ends = [clock + times.of(a) for a in steps[i:last]]
        out += [(clock, end) for end in ends]
        clock, i = max(ends), last
    return out, clock


def degraded_seconds(system: System, start: Configuration, steps: Sequence[Action], times: Durations,
                     batches: Sequence[tuple[int, int]] = ()) -> Degradation:
    """The degraded seconds of the plan `steps` from `start` (see the module's docstring for
    what counts), in time linear in the plan's length: a clock of the steps' durations, and per
    functionality the time its degraded run began. Only a degrade, an upgrade, a create or a
    remove changes which functionalities are degraded, as the actions' effects say."""
    cat = catalogue(system)
    served = start.components
    since: dict[FuncId, float] = {f: 0.0 for f in start.degraded if f[0] in served}
    per: dict[FuncId, float] = {}

    def ends(fid: FuncId, at: float) -> None:
        if fid in since:
            per[fid] = per.get(fid, 0.0) + at - since.pop(fid)

    spans, total = schedule(steps, times, batches)
    for a, (before, clock) in zip(steps, spans):
        kind, comp = a.kind, a.component
        if comp not in served:
            continue
        if kind == "degrade":
            since.setdefault((comp, getattr(a, "functionality")), clock)
        elif kind == "upgrade":
            ends((comp, getattr(a, "functionality")), clock)
        elif kind == "create":
            for f in cat.comps[comp].functionalities:
                since.setdefault((comp, f.name), clock)
        elif kind == "remove":              # its own remove does not count: it is gone after it
            for f in cat.comps[comp].functionalities:
                ends((comp, f.name), before)
    for fid in list(since):
        ends(fid, total)
    per = {f: s for f, s in per.items() if s > 0}
    weighted = sum(s * (cat.funcs[f].criticality if f in cat.funcs else 1) for f, s in per.items())
    return Degradation(total, per, weighted)
