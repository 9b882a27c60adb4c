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


def test_a_batch_s_steps_overlap_and_each_takes_effect_at_its_own_end() -> None:
    """The FTM transition's batches (checker.planning.batches): a run whose steps took exactly
    their durations, each batch's steps from the batch's start, measures what the plan expected,
    and a step of a batch takes effect at its own end, not at the batch's."""
    from checker.ftm.transition import plan_transition
    from checker.planning.durations import schedule
    from checker.planning.verified import plan_verified
    from reconf_dsl.loader import load
    plan = plan_verified(lambda: plan_transition(load([os.path.join(ROOT, "examples", "ftm", "deterministic_pbr.arch")]),
                                                 "server", "LFR").plan, use_alloy=False, chain=False).plan
    times = plan.durations()
    spans, _ = schedule(plan.steps, times, plan.batches)
    timings = [{"step": i, "action": a.kind, "at": 1000.0 + s, "seconds": e - s, "ok": True}
               for i, (a, (s, e)) in enumerate(zip(plan.steps, spans), 1)]
    doc = dict(report(), timings=timings, violated={}, outcome="done", plan_document={"plan": plan.to_dict()})
    tl = timeline(doc)
    assert tl.planned == pytest.approx(tl.end, abs=1e-3)
    for name, expected in tl.estimate.items():
        assert tl.degraded_seconds(name) == pytest.approx(expected, abs=1e-3), name
    a, b = next((a, b) for a, b in plan.batches if {s.kind for s in plan.steps[a - 1:b]} == {"degrade"})
    first = [s for s in plan.steps[a - 1:b]]
    ends = {f"{s.component}.{getattr(s, 'functionality')}": spans[i][1] for i, s in enumerate(first, a - 1)}
    for name, end in ends.items():
        assert tl.degraded[name][0].start == pytest.approx(end - spans[0][0], abs=1e-3), name


def test_the_largest_input_gaps_of_the_run_are_named() -> None:
    """A report keeps each monitored input's largest wait, and whether the run saw it; the
    timeline names those the run saw, largest first, in the text and the picture."""
    gaps = {"listener.in": {"seconds": 0.104, "during_run": True},
            "talker_v2.out_echo": {"seconds": 0.31, "during_run": True},
            "logger.in": {"seconds": 2.5, "during_run": False}}       # before the run: not the run's
    tl = timeline(dict(report(), gaps=gaps))
    assert tl.gaps == {"listener.in": 0.104, "talker_v2.out_echo": 0.31}
    text = to_text(tl)
    assert text.rstrip().splitlines()[-1] == \
        "largest input gaps during the run: talker_v2.out_echo 0.310 s, listener.in 0.104 s"
    assert "largest input gaps during the run: talker_v2.out_echo 0.310 s" in to_svg(tl)
    assert "largest input gaps" not in to_text(timeline(report()))
