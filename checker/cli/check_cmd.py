"""`reconf check PATHS`: prove that every functionality's assumptions hold (the judgement is
`checker.gate.check`)."""
from __future__ import annotations

import sys
import time
from typing import Optional

import click

from checker.alloy.engines import Engine
from checker.alloy.evaluate import start_early
from checker.cli.bag_options import bag_options, judge_bag, refuse_bag_options_alone
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
from checker.editor import warm
from checker.gate.check import check_system
from checker.reports import formats, report
from checker.reports.clock import process_age
from checker.reports.progress import status
from checker.reports.report import ReportFormat
from reconf_dsl import loader
from reconf_dsl.loader import STDIN, Sources, load
from reconf_dsl.parser import parse_text


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
    if warm.wanted() and STDIN not in files:
        _ask_warm(files, exclude, output_format, engine, bag, window, tolerance)
    served = warm.start_up()       # in a warm analyzer: the client's start-up, and which analyzer
    age = served[0] if served else process_age()     # the interpreter's start-up and imports
    started = time.perf_counter() - age
    if engine.alloy:
        start_early()              # the analyzer starts while the files are parsed
    system = load(expand(files, exclude) or nothing_left(files), sources, parse=warm.shared_parse() or parse_text)
    parsed = time.perf_counter() - started - age
    with status(f"checking {system.name}{engine.says()}…"):
        outcome = check_system(system, engine)
    outcome.recording = judge_bag(system, bag, window, tolerance)
    judging, details = outcome.timing_parts()
    details["start-up"] = f"warm: {served[1]}" if served else "cold"
    parts = [("start-up", age), ("parsing", parsed)] + judging
    wall = time.perf_counter() - started
    line = outcome.line(report.timing_note(wall, parts, details))
    human = f"[bold green]✓ safe[/]: {line}" if outcome.safe else f"[bold red]✗ unsafe[/]: {line}"
    verdict, diags = outcome.verdict, outcome.diagnostics
    rep = formats.Report("check", verdict, diags, outcome.cases(), f"{verdict}: {line}")
    emit_report(rep, output_format, sources,
                lambda: report.document("check", verdict, diags, system=system.name, files=list(system.files),
                                        engines=outcome.engines, timing=report.timing_json(wall, parts),
                                        analyzer=details["start-up"],
                                        assumptions=report.evaluation_json(outcome.judged.python),
                                        **({"recording": outcome.recording.doc} if outcome.recording else {})),
                human)
    sys.exit(EXIT_OK if outcome.safe else EXIT_UNSAFE)


def _ask_warm(files: tuple[str, ...], exclude: tuple[str, ...], output_format: ReportFormat, engine: str,
              bag: Optional[str], window: float, tolerance: float) -> None:
    """Run this check in a warm analyzer (`reconf lsp`, `reconf daemon`) if one runs: print what it
    printed and exit as it did. Returns (to run cold) when none answers."""
    argv = ["--allow-includes-outside"] if loader.settings.allow_includes_outside else []
    argv += ["check", "--output-format", output_format.value, "--engine", engine]
    for glob in exclude:
        argv += ["--exclude", glob]
    if bag is not None:
        argv += ["--bag", bag, "--window", repr(window), "--tolerance", repr(tolerance)]
    answer = warm.ask(argv + ["--", *files], process_age(), sys.stderr.isatty())
    if answer is None:
        return
    sys.stdout.write(answer.stdout)
    sys.stdout.flush()
    sys.stderr.write(answer.stderr)
    sys.stderr.flush()
    sys.exit(answer.exit)
