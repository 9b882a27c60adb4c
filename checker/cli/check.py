"""`reconf check PATHS`: prove that every functionality's assumptions hold (the judgement is
`checker.gate.check`)."""
from __future__ import annotations

import sys
import time
from typing import Optional

import click

from checker.alloy.engines import Engine
from checker.alloy.evaluate import start_early
from checker.cli.common import (
    EXIT_OK,
    EXIT_UNSAFE,
    emit_report,
    engine_option,
    format_option,
    guarded,
    solver_option_unused,
)
from checker.cli.inputs import exclude_option, expand, nothing_left, paths_argument
from checker.cli.recording import bag_options, judge_bag, refuse_bag_options_alone
from checker.gate.check import check_system
from checker.reports import formats, report
from checker.reports.progress import status
from checker.reports.report import ReportFormat
from reconf_dsl.loader import Sources, load


@click.command()
@paths_argument
@exclude_option
@format_option
@engine_option
@solver_option_unused
@bag_options
@guarded("check")
def check(files: tuple[str, ...], exclude: tuple[str, ...], output_format: ReportFormat, engine: Engine, solver: str,
          bag: Optional[str], window: float, tolerance: float, sources: Sources) -> None:
    """Prove that every functionality's assumptions hold in PATHs (one system; includes followed;
    a directory stands for the .arch files under it).

    Lists each assumption that does not hold with its chain: functionality → assumption →
    input → connector → each attached output and why it falls short. With --bag, also judges
    every rate and message type against a rosbag2 recording (docs/recordings.md).
    """

    del solver     # no effect on a check (solver_option_unused)
    refuse_bag_options_alone(bag)
    age = report.process_age()     # the interpreter's start-up and imports
    started = time.perf_counter() - age
    if engine.alloy:
        start_early()              # the analyzer starts while the files are parsed
    system = load(expand(files, exclude) or nothing_left(files), sources)
    parsed = time.perf_counter() - started - age
    with status(f"checking {system.name}{engine.says()}…"):
        outcome = check_system(system, engine)
    outcome.recording = judge_bag(system, bag, window, tolerance)
    judging, details = outcome.timing_parts()
    parts = [("start-up", age), ("parsing", parsed)] + judging
    wall = time.perf_counter() - started
    line = outcome.line(report.timing_note(wall, parts, details))
    human = f"[bold green]✓ safe[/]: {line}" if outcome.safe else f"[bold red]✗ unsafe[/]: {line}"
    verdict, diags = outcome.verdict, outcome.diagnostics
    rep = formats.Report("check", verdict, diags, outcome.cases(), f"{verdict}: {line}")
    emit_report(rep, output_format, sources,
                lambda: report.document("check", verdict, diags, system=system.name, files=list(system.files),
                                        engines=outcome.engines, timing=report.timing_json(wall, parts),
                                        assumptions=report.evaluation_json(outcome.judged.python),
                                        **({"recording": outcome.recording.doc} if outcome.recording else {})),
                human)
    sys.exit(EXIT_OK if outcome.safe else EXIT_UNSAFE)
