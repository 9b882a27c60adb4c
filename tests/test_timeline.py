"""`reconf timeline`: a run report drawn as a timeline (checker/reports/timeline.py,
docs/executor.md#a-picture-of-a-run). The report is a real one: the chatter talker's replacement
of `bench_faults` run 0, whose talker was killed before step 4 (the detach waited 10 s for data
from the talker that stays, then failed)."""
from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.reports.timeline import timeline, to_svg, to_text
from tests.examples_table import ROOT

REPORT = os.path.join(ROOT, "examples", "runs", "chatter_talker_killed.json")


def report() -> dict:
    with open(REPORT, encoding="utf-8") as fh:
        doc: dict = json.load(fh)
    return doc


def test_each_step_from_its_start_to_its_end_as_timed() -> None:
    doc = report()
    tl = timeline(doc)
    t0 = doc["timings"][0]["at"]
    assert [(b.start, b.end, b.ok) for b in tl.steps] == [
        pytest.approx((t["at"] - t0, t["at"] - t0 + t["seconds"], t["ok"])) for t in doc["timings"]]
    assert [b.label for b in tl.steps] == ["  1. + create talker_v2", "  2. ↑ upgrade talker_v2.talk",
                                           "  3. → attach talker_v2.out to /chatter",
                                           "  4. × detach talker.out from /chatter"]


def test_a_degraded_span_runs_from_the_step_that_degraded_to_the_one_that_upgraded() -> None:
    """talker_v2 is created degraded (step 1) and upgraded by step 2: degraded for step 2's time."""
    tl = timeline(report())
    assert sorted(tl.degraded) == ["talker_v2.talk"]
    [span] = tl.degraded["talker_v2.talk"]
    assert (span.start, span.end) == (tl.steps[0].end, tl.steps[1].end)


def test_the_text_says_where_the_seconds_went() -> None:
    text = to_text(timeline(report()), width=40)
    assert text.startswith("chatter: 4 of 5 steps timed, failed, 11.02 s")
    detach = next(line for line in text.splitlines() if "detach talker.out" in line)
    assert detach.endswith("10.001 s FAILED") and "✗" in detach
    assert all(len(line.split("|")[1]) == 40 for line in text.splitlines()[1:])


def test_the_svg_is_one_picture_with_a_bar_for_each_step_and_span() -> None:
    tl = timeline(report())
    svg = ET.fromstring(to_svg(tl))
    rects = svg.findall("{http://www.w3.org/2000/svg}rect")
    assert len(rects) == len(tl.steps) + 1
    assert [r.get("fill") for r in rects].count("#c0392b") == 1       # the failed step


def test_the_command(tmp_path: Path) -> None:
    r = CliRunner().invoke(main, ["timeline", REPORT, "--width", "30"])
    assert r.exit_code == 0 and "4. × detach talker.out from /chatter" in r.stdout, r.output
    out = tmp_path / "run.svg"
    r = CliRunner().invoke(main, ["timeline", REPORT, "-o", str(out)])
    assert r.exit_code == 0 and ET.parse(out).getroot().tag.endswith("svg")
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"kind": "plan"}))
    r = CliRunner().invoke(main, ["timeline", str(other)])
    assert r.exit_code == 2 and "not a run report" in r.output


def test_a_monitor_that_saw_a_violation_is_marked_after_its_step() -> None:
    """The report's `violated` (the executor's: each monitor whose count moved, how often, the
    step after which it was first seen) is drawn at that step's end."""
    doc = dict(report(), violated={"listener": {"violations": 2, "after_step": 3}})
    tl = timeline(doc)
    assert tl.violated == {"listener": (2, tl.steps[2].end)}
    line = to_text(tl, width=40).splitlines()[-1]
    assert line.startswith("listener") and "2 violations, first seen after the step ending at" in line
    assert "monitor of listener: 2 violations" in to_svg(tl)


def test_the_plan_s_estimate_is_the_quantity_the_timeline_measures() -> None:
    """A run whose every step took exactly the plan's duration for it shows each functionality
    degraded for exactly the seconds the plan expected (checker.planning.durations)."""
    from checker.planning import plan_replace
    from reconf_dsl.loader import load
    plan = plan_replace(load([os.path.join(ROOT, "examples", "chatter.arch")]), "talker", "talker_v2",
                        strategy="paper")
    times, at, timings = plan.durations(), 1000.0, []
    for i, a in enumerate(plan.steps, 1):
        timings.append({"step": i, "action": a.kind, "at": at, "seconds": times.of(a), "ok": True})
        at += times.of(a)
    doc = dict(report(), timings=timings, violated={}, outcome="done",
               plan_document={"plan": plan.to_dict()})
    tl = timeline(doc)
    assert tl.estimate == {"listener.listen": pytest.approx(tl.degraded_seconds("listener.listen"))}
    assert tl.planned == pytest.approx(tl.end, abs=1e-3)
    line = next(x for x in to_text(tl).splitlines() if x.startswith("listener.listen"))
    assert line.endswith(f"(plan ~{tl.estimate['listener.listen']:.2f} s)")
