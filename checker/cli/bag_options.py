"""The options `check --bag` adds, and the one call it makes (checker/reality/recording.py judges;
docs/recordings.md)."""
from __future__ import annotations

from typing import Any, Callable, Optional

import click

from checker.cli.common import Failure
from checker.reality.recording import RecordingVerdict, Unreadable, judge_recording
from checker.reports.progress import status
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import System
from reconf_dsl.span import Span

__all__ = ["bag_options", "judge_bag", "refuse_bag_options_alone"]


def bag_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    for option in reversed((
        click.option("--bag", type=click.Path(), default=None, metavar="RECORDING",
                     help="also judge every rate and message type against a rosbag2 recording: its directory, "
                          "or a .db3 or .mcap file"),
        click.option("--window", type=click.FloatRange(min=0, min_open=True), default=1.0, show_default=True,
                     metavar="SECONDS", help="with --bag: the sliding window a topic's rate is measured over"),
        click.option("--tolerance", type=click.FloatRange(min=0, max=100, max_open=True), default=10.0,
                     show_default=True, metavar="PERCENT",
                     help="with --bag: a rate this far under the model's is still taken as met"),
    )):
        fn = option(fn)
    return fn


def refuse_bag_options_alone(bag: Optional[str]) -> None:
    """--window and --tolerance without --bag are a usage error, not silently ignored."""
    ctx = click.get_current_context(silent=True)
    given = [f"--{name}" for name in ("window", "tolerance") if bag is None and ctx is not None and
             ctx.get_parameter_source(name) not in (None, click.core.ParameterSource.DEFAULT)]
    if given:
        raise click.UsageError(f"{' and '.join(given)} {'is' if len(given) == 1 else 'are'} only read with "
                               "--bag RECORDING")


def judge_bag(system: System, bag: Optional[str], window: float, tolerance: float) -> Optional[RecordingVerdict]:
    """The recording's verdict, or None without --bag; an unreadable recording is RC701, and one
    that judged nothing RC706: exit 2, a question not answered."""
    if bag is None:
        return None
    try:
        with status(f"reading {bag}…"):
            verdict = judge_recording(system, bag, window, tolerance)
    except Unreadable as e:
        raise Failure([Diagnostic("RC701", Severity.ERROR, f"cannot read the recording {bag}: {e}",
                                  Span.unknown(bag), notes=("a rosbag2 recording is a directory with "
                                                            "metadata.yaml, or a .db3 (sqlite3) or .mcap file",))]) \
            from None
    if not verdict.answered:
        raise Failure(verdict.diagnostics)
    return verdict
