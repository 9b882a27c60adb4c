"""`check --bag`: the model's rates and types judged against a rosbag2 recording.

Every rate the deployed configuration states (a topic's own predicate, an output's guarantee, an
input's or a functionality's assumption, an environment guarantee) is compared with the observed rate of its topic (the worst
sliding window, checker/reality/rates.py), and every message type with the type the recording holds.
docs/recordings.md gives the computation and what a finding proves: a recording does not say
which publisher sent a message, so a guarantee is judged on its topic's rate, all publishers."""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

from checker.reality.bag import Recording, Unreadable, open_recording
from checker.reality.rates import NS, RateMeter, Worst
from checker.reports.formats import CheckCase
from checker.reports.report import span_json
from checker.semantic_model.semantics import rate_text
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import Predicate, System
from reconf_dsl.span import Span
from reconf_dsl.words import plural

__all__ = ["Promise", "promises", "Judgement", "RecordingVerdict", "judge_recording", "Unreadable"]


@dataclass(frozen=True)
class Promise:
    """A rate or type the model states, and the topics it is judged on: `topics` None for the
    environment's (the recorded topics of its type that no connector names); any one suffices."""

    kind: str                 # topic | guarantee | input | assumption | environment
    who: str                  # `talker.talk guarantees`, `topic /chatter promises`
    predicate: Predicate
    ros_type: Optional[str]
    topics: Optional[tuple[str, ...]]
    span: Span
    publishers: int = 1       # a guarantee's: the outputs the model attaches to its topic


def promises(system: System) -> list[Promise]:
    """What the deployed configuration (every component present, every functionality normal, every
    attachment in place) states of its topics' rates and types, in the model's order. Services are
    not judged: rosbag2 records topics."""
    def ros(msg: Optional[str]) -> Optional[str]:
        m = system.message(msg) if msg else None
        return m.ros_type if m else None
    topics = [k for k in system.connectors if k.kind == "topic"]
    out = [Promise("topic", f"topic {k.name} promises", k.guarantee, ros(k.guarantee.message), (k.name,),
                   _span(k.guarantee.span, k.span)) for k in topics]
    for c in system.components:
        for port in c.inputs:
            fed = tuple(k.name for k in topics if any((r.component, r.port) == (c.name, port.name) for r in k.subscribers))
            if fed and port.assumption is not None:
                out.append(Promise("input", f"input {c.name}.{port.name} assumes", port.assumption, ros(port.message),
                                   fed, _span(port.assumption.span, port.span)))
        for f in c.functionalities:
            if f.normal is None:
                continue
            for g in (g for g in f.normal.guarantees if not g.predicate.is_nothing):
                out += [Promise("guarantee", f"{c.name}.{f.name} guarantees", g.predicate, ros(g.predicate.message),
                                (k.name,), _span(g.span, f.span), len(k.publishers))
                        for k in topics if any((r.component, r.port) == (c.name, g.port) for r in k.publishers)]
            for a in f.normal.assumptions:
                fed = tuple(k.name for k in topics if k.guarantee.message == a.message and any(
                    r.component == c.name and r.port in f.ports for r in k.subscribers))
                out.append(Promise("assumption", f"{c.name}.{f.name} assumes", a, ros(a.message), fed or None,
                                   _span(a.span, f.span)))
    out += [Promise("environment", f"environment {e.name} guarantees", e.guarantee, ros(e.guarantee.message),
                    None, _span(e.guarantee.span, e.span)) for e in system.environment]
    return out


def _span(*spans: Span) -> Span:
    return next((s for s in spans if not s.file.startswith("<")), spans[-1])


@dataclass
class Judgement:
    """One promise's outcome: `verdict` met | contradicted | not judged, and why."""

    promise: Promise
    verdict: str
    evidence: str
    topics: tuple[str, ...] = ()
    worst: Optional[Worst] = None
    topic: Optional[str] = None       # the topic whose worst window is `worst`


@dataclass
class RecordingVerdict:
    diagnostics: list[Diagnostic]
    judgements: list[Judgement]
    summary: str
    doc: dict[str, Any]
    seconds: float = 0.0      # reading and judging the recording

    @property
    def contradicted(self) -> bool:
        return any(d.is_error for d in self.diagnostics)

    @property
    def answered(self) -> bool:
        """False when no promise was judged at all (RC706): a question not answered, not a pass."""
        return any(j.verdict != "not judged" for j in self.judgements)

    def cases(self, system: str) -> list[CheckCase]:
        """One JUnit/SARIF case per promise judged."""
        return [CheckCase(f"{system}.recording", f"{j.promise.who} {j.promise.predicate}",
                          j.evidence if j.verdict == "contradicted" else None, j.evidence, j.promise.span)
                for j in self.judgements if j.verdict != "not judged"]


def judge_recording(system: System, path: str, window: float = 1.0, tolerance: float = 10.0) -> RecordingVerdict:
    """Judge `system`'s deployed promises against the recording at `path` (`Unreadable` when it
    cannot be read). A rate down to `tolerance` percent under the model's is taken as met."""
    began = time.perf_counter()
    ps = promises(system)
    with open_recording(path) as rec:
        diags = _types_and_absences(system, rec)
        wrong = {t for d, t in diags if d.code == "RC703"}
        named = {k.name for k in system.connectors if k.kind == "topic"}
        sources = [_sources(p, rec, named, wrong) for p in ps]
        judged = sorted({t for s in sources for t in s})
        short = rec.messages == 0 or rec.closed - rec.opened < window * NS
        worst = {} if short else _measure(rec, judged, window)
    js = [_judge(p, s, worst, window, tolerance, short, wrong) for p, s in zip(ps, sources)]
    out = [d for d, _ in diags]
    if short and any(j.promise.predicate.rate is not None for j in js):
        out.append(Diagnostic("RC705", Severity.WARNING,
                              f"the recording lasts {(rec.closed - rec.opened) / NS:.2f} s, less than the {window:g} s "
                              "window: no rate is judged", Span.unknown(path),
                              notes=("record for longer, or judge over a shorter --window",)))
    out += [_absent(j) for j in js if j.verdict == "not judged" and not j.topics and j.promise.topics is None]
    out += [_contradiction(j, tolerance) for j in js if j.verdict == "contradicted" and j.worst is not None]
    if not any(j.verdict != "not judged" for j in js):
        out.append(_nothing_judged(rec, js))
    verdict = _verdict(rec, out, js, judged, window, tolerance)
    verdict.seconds = time.perf_counter() - began
    return verdict


def _nothing_judged(rec: Recording, js: list[Judgement]) -> Diagnostic:
    held = ", ".join(sorted(rec.topics)[:8]) + (", …" if len(rec.topics) > 8 else "")
    return Diagnostic("RC706", Severity.ERROR,
                      f"the recording {rec.path} judged none of the model's {plural(len(js), 'promise')}: "
                      "the question is not answered", Span.unknown(rec.path),
                      notes=(f"the recording holds {held or 'no topic'}" if rec.messages or rec.topics
                             else "the recording holds no message",
                             "a modelled topic missing from it is RC704, a recording shorter than --window RC705: "
                             "check the recording and the topics' names"))


def _types_and_absences(system: System, rec: Recording) -> list[tuple[Diagnostic, str]]:
    """A recorded type other than the model's (an error), a modelled topic not recorded (a warning)."""
    out = []
    for k in (k for k in system.connectors if k.kind == "topic"):
        m = system.message(k.guarantee.message) if k.guarantee.message else None
        span = _span(k.guarantee.span, k.span)
        t = rec.topics.get(k.name)
        if t is None:
            out.append((Diagnostic("RC704", Severity.WARNING, f"{k.name} is not in the recording: its rates and type "
                                   "are not judged (not evidence either way)", span), k.name))
        elif m is not None and t.types != (m.ros_type,):
            out.append((Diagnostic("RC703", Severity.ERROR, f"{k.name} is recorded as {' and '.join(t.types)}; the "
                                   f"model says {m.name} = {m.ros_type}", span), k.name))
    return out


def _sources(p: Promise, rec: Recording, named: set[str], wrong: set[str]) -> tuple[str, ...]:
    """The recorded topics `p` is judged on: its own, or for the environment's, every recorded
    topic of its type that no connector names; a topic of the wrong type is not judged for rates."""
    if p.topics is not None:
        return tuple(t for t in p.topics if t in rec.topics and t not in wrong)
    return tuple(sorted(t.name for t in rec.topics.values() if t.name not in named and p.ros_type in t.types))


def _measure(rec: Recording, topics: list[str], window: float) -> dict[str, Optional[Worst]]:
    """Each topic's worst window, in one streaming pass over the recording; a window at the
    recording's start only where the recorder said when it started (a topic's first message
    otherwise: recorders subscribe to topics one at a time)."""
    meters = {t: RateMeter(round(window * NS), rec.opened, rec.bounds is not None) for t in topics}
    for topic, stamp in rec.stamps(topics):
        meters[topic].feed(stamp)
    return {t: m.finish(rec.closed) for t, m in meters.items()}


def _judge(p: Promise, topics: tuple[str, ...], worst: dict[str, Optional[Worst]], window: float,
           tolerance: float, short: bool, wrong: set[str]) -> Judgement:
    if not topics:
        if p.topics and all(t in wrong for t in p.topics):
            return Judgement(p, "contradicted", f"{', '.join(p.topics)}: recorded with another type")
        return Judgement(p, "not judged", "not in the recording")
    if p.predicate.rate is None:
        return Judgement(p, "met", f"{', '.join(topics)}: recorded with the type {p.ros_type}", topics)
    seen = [(w, t) for t in topics if (w := worst.get(t)) is not None]
    if short or not seen:
        return Judgement(p, "not judged", f"the recording is shorter than the {window:g} s window", topics)
    w, topic = max(seen, key=lambda x: x[0].hz)     # any one topic suffices
    hz = float(p.predicate.rate.hz)
    met = w.hz >= hz * (1 - tolerance / 100)
    text = f"{_observed(topic, w, window)}; {p.who} {rate_text(p.predicate)}{_scope(p, topics, topic)}"
    return Judgement(p, "met" if met else "contradicted", text, topics, w, topic)


def _observed(topic: str, w: Worst, window: float) -> str:
    at = f"{w.at:.{1 if window >= 1 else 2 if window >= 0.1 else 3}f}"     # t as fine as the window
    end = ", to the recording's end" if w.to_end else ""
    gap = f" (no message for {w.gap:.2f} s{end})" if w.gap is not None else ""
    return f"{topic}: {hz_text(w.hz)} Hz over the worst {window:g} s window at t = {at} s{gap}"


def _scope(p: Promise, topics: tuple[str, ...], topic: str) -> str:
    """What the observation is of: a topic carries every publisher's messages, unnamed."""
    if p.kind == "guarantee":
        if p.publishers > 1:
            owner = p.who.split(".", 1)[0]
            return (f" (the topic's rate, all {p.publishers} publishers: a finding on the topic, not proved of "
                    f"{owner} alone)")
        return " (the topic's rate, all publishers)"
    if p.topics is None:
        return f" (judged on {topic}: recorded with type {p.ros_type}, named by no connector)"
    if len(topics) > 1:
        return f" (the best of {', '.join(topics)})"
    return ""


def _absent(j: Judgement) -> Diagnostic:
    return Diagnostic("RC704", Severity.WARNING,
                      f"{j.promise.who} {j.promise.predicate}, but the recording has no topic of type "
                      f"{j.promise.ros_type} that no connector names: not judged (not evidence either way)", j.promise.span)


def _contradiction(j: Judgement, tolerance: float) -> Diagnostic:
    notes = (f"the recording contradicts the model: rates down to {tolerance:g}% under the model's are taken as met "
             "(--tolerance), as log times are the recorder's receive times",)
    return Diagnostic("RC702", Severity.ERROR, j.evidence, j.promise.span, notes=notes)


def hz_text(hz: float) -> str:
    return f"{hz:.0f}" if hz >= 100 else f"{hz:.3g}"


def _verdict(rec: Recording, diags: list[Diagnostic], js: list[Judgement], judged: list[str], window: float,
             tolerance: float) -> RecordingVerdict:
    rated = [j for j in js if j.promise.predicate.rate is not None and j.verdict != "not judged"]
    bad = [j for j in rated if j.verdict == "contradicted"]
    types = sum(1 for d in diags if d.code == "RC703")
    messages = sum(rec.topics[t].count for t in judged)
    seconds = (rec.closed - rec.opened) / NS
    held = f"{len(bad)} contradicted" if bad else "all met"
    line = (f"recording {Path(rec.path).name}: {plural(len(judged), 'topic')}, {plural(messages, 'message')} over "
            f"{seconds:.1f} s judged against {plural(len(rated), 'rate')}, {held}")
    if types:
        line += f", {plural(types, 'type mismatch', 'type mismatches')}"
    skipped = sum(1 for j in js if j.verdict == "not judged")
    if skipped:
        line += f", {skipped} not judged"
    doc = {"path": rec.path, "storage": rec.storage, "window": window, "tolerance": tolerance,
           "seconds": round(seconds, 6), "messages": rec.messages,
           "bounds": "recorder" if rec.bounds else "messages",
           "judged": {"topics": judged, "messages": messages, "seconds": round(seconds, 6)},
           "promises": [_judgement_json(j) for j in js]}
    return RecordingVerdict(diags, js, line, doc)


def _judgement_json(j: Judgement) -> dict[str, Any]:
    p, w = j.promise, j.worst
    return {"kind": p.kind, "who": p.who, "predicate": str(p.predicate), "span": span_json(p.span),
            "hz": None if p.predicate.rate is None else float(p.predicate.rate.hz), "verdict": j.verdict,
            "evidence": j.evidence, "topics": list(j.topics), "topic": j.topic,
            "observed": None if w is None else {"hz": round(w.hz, 6), "t": round(w.at, 6), "gap": w.gap,
                                                "to_end": w.to_end}}
