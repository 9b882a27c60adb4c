"""The options every `reconf plan ...` command takes, in one place.

Kept apart from `checker.cli.plan_cmd` so that commands registered from other packages (the
FTM transition) can share them without importing the CLI while it is being built."""
from __future__ import annotations

from typing import Any, Callable

import click

from checker.alloy.engines import Engine
from checker.planning.strategies import REGISTRY, STRATEGIES
from checker.reports.report import OutputFormat

file_option = click.option(
    "-f", "--file", "files", multiple=True, type=click.Path(dir_okay=False),
    help="the deployed architecture (repeatable; default: the one *.arch here, or $RECONF_ARCH)")

plan_options: list[Callable[[Any], Any]] = [
    click.option("--strategy", type=click.Choice(STRATEGIES), default="default", show_default=True,
                 help="; ".join(f"{s.name}: {s.summary}" for s in REGISTRY.values())
                 + "; when one finds no plan, the next plans"),
    click.option("--alloy/--no-alloy", "use_alloy", default=True, show_default=True,
                 help="also verify the whole plan in the Alloy Analyzer"),
    click.option("--engine", type=click.Choice([Engine.PYTHON.value, Engine.ALLOY.value]), default=Engine.PYTHON.value,
                 show_default=True, callback=lambda c, p, v: Engine(v),
                 help="alloy: ask Alloy 6 for a least-disruptive plan of at most --max-steps steps (small systems)"),
    click.option("--max-steps", type=click.IntRange(1, 64), default=12, show_default=True,
                 help="with --engine alloy: the longest plan considered"),
    click.option("-o", "--output", type=click.Path(dir_okay=False), help="write the plan as a ROS 2 Python script"),
    click.option("--output-format", "output_format", type=click.Choice([f.value for f in OutputFormat]),
                 default="text", show_default=True, callback=lambda c, p, v: OutputFormat(v)),
    click.option("--durations", "durations_from", metavar="REPORT", type=click.Path(dir_okay=False),
                 help="estimate the plan's seconds with the step times a run report measured (medians per "
                      "action and component) instead of the measured defaults and `takes` lines"),
    click.option("--detailed-exitcode", "detailed_exitcode", is_flag=True,
                 help="exit 0 when there is nothing to do, 3 for a safe plan with steps (1 and 2 as always)"),
]


def with_plan_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Strategy, engines, script and output format (for commands that name their own inputs)."""
    for option in reversed(plan_options):
        fn = option(fn)
    return fn


def with_common(fn: Callable[..., Any]) -> Callable[..., Any]:
    """`-f FILE` and every plan option (for commands that plan on the deployed architecture)."""
    return file_option(with_plan_options(fn))
