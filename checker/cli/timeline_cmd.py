"""`reconf timeline REPORT`: a run drawn as a timeline, from the run report a plan script,
`reconf up`, `down` or `recover` wrote (`--report`): each step's start and end, each
functionality's degraded span (docs/executor.md#a-picture-of-a-run)."""
from __future__ import annotations

import sys
from typing import Any, Optional

import click

from checker.cli.common import guarded, read_run_report, write_atomically
from checker.reports.timeline import timeline, to_svg, to_text


@click.command("timeline")
@click.argument("report", type=click.Path(dir_okay=False, exists=True))
@click.option("-o", "--output", type=click.Path(dir_okay=False), metavar="FILE",
              help="write an SVG picture here instead of printing the text timeline")
@click.option("--width", type=click.IntRange(min=10, max=400), default=60, show_default=True,
              help="columns of the text timeline's time axis")
@guarded("timeline")
def timeline_cmd(report: str, output: Optional[str], width: int, **_: Any) -> None:
    """Draw the run of REPORT as a timeline: each step from its start to its end, as the executor
    timed it, then each functionality that was degraded, from the step that degraded it to the
    one that upgraded it. Where the seconds of a run went, at a glance.

    \b
    Examples:
      python plan.py --yes --report run.json && reconf timeline run.json
      reconf timeline run.json -o run.svg
    """
    tl = timeline(read_run_report(report, "plan_document", "a run report (written by --report of a plan script, "
                                  "`reconf up`, `down` or `recover`)"))
    if output:
        write_atomically(output, to_svg(tl))
        click.echo(f"wrote {output}", err=True)
        return
    sys.stdout.write(to_text(tl, width=width))
