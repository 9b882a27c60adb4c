"""A run drawn as a timeline (docs/executor.md#a-picture-of-a-run), from its run report: each step
from its start to its end as the executor timed it, and each functionality's degraded span,
from the end of the step that degraded it (or the run's start) to the end of the step that
upgraded it (or the run's end). Every step a report times was confirmed on the wire before the
next began, or, in a batch, before the batch's end (docs/control-interface.md#the-six-actions,
docs/executor.md#batches), so a span is what the nodes showed, to the step. Each monitor that saw a normal mode's assumption violated is marked where the executor first
saw it (after a step; a report written before the run carried this says nothing of it), and the
largest waits for data the monitored inputs saw during the run. As text for a terminal, or SVG."""
from __future__ import annotations

from dataclasses import dataclass, field
from html import escape
from typing import Any

from checker.planning.durations import most_first
from reconf_ros.executor.plan_states import PlanStates, degraded_spans

__all__ = ["Bar", "Timeline", "timeline", "to_text", "to_svg"]

SYMBOLS = {"create": "+", "remove": "-", "attach": "→", "detach": "×", "upgrade": "↑", "degrade": "↓"}


@dataclass
class Bar:
    label: str
    start: float        # s from the run's first step
    end: float
    ok: bool = True


@dataclass
class Timeline:
    title: str
    outcome: str
    steps: list[Bar] = field(default_factory=list)
    degraded: dict[str, list[Bar]] = field(default_factory=dict)    # "comp.func" -> its spans
    violated: dict[str, tuple[int, float]] = field(default_factory=dict)   # monitor -> (violations, first seen at)
    # the plan's estimate (checker.planning.durations): its seconds in all, and "comp.func" -> the
    # seconds it expected each functionality that served before the plan to stay degraded
    planned: float = 0.0
    estimate: dict[str, float] = field(default_factory=dict)
    # "comp.port" -> the largest wait for data a monitored input saw during the run (s), as its
    # node's last status said (absent from reports written before the run kept them)
    gaps: dict[str, float] = field(default_factory=dict)

    @property
    def end(self) -> float:
        return max((b.end for b in self.steps), default=0.0)

    def degraded_seconds(self, name: str) -> float:
        return sum(b.end - b.start for b in self.degraded.get(name, []))

    def gaps_note(self, shown: int = 3) -> str:
        """The largest input gaps the monitors saw during the run, most first ("" if none)."""
        return most_first(self.gaps, shown, digits=3)

    def planned_note(self) -> str:
        """What the plan expected the run to take, for the title ("" for a plan without seconds)."""
        return f" (the plan expected ~{self.planned:.2f} s)" if self.planned else ""

    def expected(self, name: str) -> str:
        """What the plan expected of the degraded row `name`, for its end ("" if nothing)."""
        return f" (plan ~{self.estimate[name]:.2f} s)" if name in self.estimate else ""


def _describe(step: dict[str, Any]) -> str:
    a = step["action"]
    where = f"{step['component']}.{step.get('functionality') or step.get('port') or ''}".rstrip(".")
    to = f" {'to' if a == 'attach' else 'from'} {step['connector']}" if step.get("connector") else ""
    return f"{SYMBOLS.get(a, '?')} {a} {where}{to}"


def timeline(report: dict[str, Any]) -> Timeline:
    """The timeline of a run report (`--report` of a plan script, `reconf up`, `recover`)."""
    plan = report["plan_document"]["plan"]
    steps, states = plan["steps"], PlanStates(plan)
    timings = sorted(report.get("timings") or [], key=lambda t: t["step"])
    tl = Timeline(f"{report.get('system', '?')}: {len(timings)} of {len(steps)} steps timed",
                  str(report.get("outcome", "?")))
    seconds = plan.get("seconds") or {}      # absent from plans made before estimates were
    tl.planned = float(seconds.get("plan", 0.0))
    tl.estimate = {f"{f['component']}.{f['functionality']}": float(f["seconds"])
                   for f in seconds.get("functionalities", [])}
    tl.gaps = {k: float(g["seconds"]) for k, g in (report.get("gaps") or {}).items() if g.get("during_run")}
    if not timings:
        return tl
    t0 = timings[0]["at"]
    for t in timings:
        tl.steps.append(Bar(f"{t['step']:3d}. {_describe(steps[t['step'] - 1])}", t["at"] - t0,
                            t["at"] - t0 + t["seconds"], bool(t["ok"])))
    _degraded_spans(tl, timings, states, steps)
    ends = {t["step"]: b.end for t, b in zip(timings, tl.steps)}
    for comp, v in sorted((report.get("violated") or {}).items()):
        tl.violated[comp] = (int(v["violations"]), ends.get(int(v["after_step"]), 0.0))
    return tl


def _degraded_spans(tl: Timeline, timings: list[dict[str, Any]], states: PlanStates,
                    steps: list[dict[str, Any]]) -> None:
    """Each functionality's degraded spans, as `degraded_spans` times them from the steps' bars."""
    timed = [(t["step"], b.start, b.end, bool(t["ok"])) for t, b in zip(timings, tl.steps)]
    removes = {t["step"] for t in timings if steps[t["step"] - 1]["action"] == "remove"}
    for name, spans in degraded_spans(states, timed, removes, tl.end).items():
        tl.degraded[name] = [Bar(name, a, b) for a, b in spans]


def _row(bars: list[Bar], scale: float, width: int, mark: str) -> str:
    cells = [" "] * width
    for b in bars:
        lo = min(width - 1, int(b.start * scale))
        hi = max(lo + 1, min(width, int(round(b.end * scale))))
        for i in range(lo, hi):
            cells[i] = mark if b.ok else "✗"
    return "".join(cells)


def to_text(tl: Timeline, width: int = 60, label: int = 48) -> str:
    """One line a step, then one a functionality that was degraded, on one time axis."""
    if not tl.steps:
        return f"{tl.title}: no step was timed ({tl.outcome})\n"
    scale = width / max(tl.end, 1e-6)
    lines = [f"{tl.title}, {tl.outcome}, {tl.end:.2f} s{tl.planned_note()}; one column is {tl.end / width:.3f} s",
             f"{'step':<{label}} |{'0 s':<{width - 8}}{tl.end:>6.2f} s|"]
    for b in tl.steps:
        lines.append(f"{b.label[:label]:<{label}} |{_row([b], scale, width, '█')}| {b.end - b.start:6.3f} s"
                     + ("" if b.ok else " FAILED"))
    if tl.degraded:
        lines.append(f"{'degraded':<{label}} |{'-' * width}|")
    for name in sorted(tl.degraded):
        lines.append(f"{name[:label]:<{label}} |{_row(tl.degraded[name], scale, width, '░')}| "
                     f"{tl.degraded_seconds(name):6.3f} s{tl.expected(name)}")
    if tl.violated:
        lines.append(f"{'monitors that saw a violation':<{label}} |{'-' * width}|")
    for comp, (n, at) in sorted(tl.violated.items()):
        lines.append(f"{comp[:label]:<{label}} |{_row([Bar(comp, at, at)], scale, width, '!')}| "
                     f"{n} violation{'s' if n != 1 else ''}, first seen after the step ending at {at:.2f} s")
    if tl.gaps:
        lines.append(f"largest input gaps during the run: {tl.gaps_note()}")
    return "\n".join(lines) + "\n"


def to_svg(tl: Timeline, width: int = 900, label: int = 380, row: int = 16) -> str:
    """The same timeline as an SVG picture: steps in blue (red where one failed), degraded
    spans in orange, violations in purple, each row labelled, a second scale along the top."""
    marks = [Bar(f"monitor of {c}: {n} violations", at, at) for c, (n, at) in sorted(tl.violated.items())]
    rows = [(b, "#c0392b" if not b.ok else "#2e86c1") for b in tl.steps]
    rows += [(b, "#e67e22") for name in sorted(tl.degraded) for b in tl.degraded[name]]
    rows += [(b, "#8e44ad") for b in marks]
    names = [b.label for b in tl.steps] + sorted(tl.degraded) + [b.label for b in marks]
    scale = (width - label - 10) / max(tl.end, 1e-6)
    height = row * (len(names) + 3 + bool(tl.gaps))
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="monospace" '
           f'font-size="11">', f'<text x="4" y="{row}">{escape(tl.title)}, {escape(tl.outcome)}, {tl.end:.2f} s'
           f'{tl.planned_note()}</text>']
    for s in range(int(tl.end) + 1):
        x = label + s * scale
        out.append(f'<line x1="{x:.1f}" y1="{row * 1.5:.0f}" x2="{x:.1f}" y2="{height}" stroke="#ddd"/>'
                   f'<text x="{x + 2:.1f}" y="{row * 2 - 2}" fill="#888">{s} s</text>')
    index = {name: i for i, name in enumerate(names)}
    for i, name in enumerate(names):
        out.append(f'<text x="4" y="{row * (i + 3) - 4}">{escape(name[:60])}{tl.expected(name)}</text>')
    for b, colour in rows:
        y = row * (index[b.label] + 2) + 2
        out.append(f'<rect x="{label + b.start * scale:.1f}" y="{y}" width="{max(1.0, (b.end - b.start) * scale):.1f}" '
                   f'height="{row - 4}" fill="{colour}"><title>{escape(b.label)}: {b.start:.3f}-{b.end:.3f} s'
                   f'</title></rect>')
    if tl.gaps:
        out.append(f'<text x="4" y="{row * (len(names) + 3) - 4}">largest input gaps during the run: '
                   f'{escape(tl.gaps_note())}</text>')
    return "\n".join(out + ["</svg>"]) + "\n"
