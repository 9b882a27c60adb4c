"""`reconf graph FILES` draws an architecture; `reconf graph-plan OLD NEW` the plan from one to the
other (`checker.reports.pictures`)."""
from __future__ import annotations

from typing import Optional

import click

from checker.cli.common import (
    EXIT_UNSAFE,
    Failure,
    draw,
    files_argument,
    force_option,
    guarded,
    picture_format_for,
    picture_format_option,
    write_pictures,
)
from checker.ftm.plan_change import plan_change
from checker.gate.revisions import path_to_load, revisions
from checker.planning import STRATEGIES, Fallback, NoSafePlan
from checker.reports.pictures import picture, plan_picture, step_pictures
from checker.reports.progress import status
from checker.reports.report import OutputFormat
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.loader import Sources, load


@click.command()
@files_argument
@picture_format_option
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write to a file instead of stdout")
@force_option
@guarded("graph")
def graph(files: tuple[str, ...], picture_format: Optional[str], output: Optional[str], force: bool,
          sources: Sources, output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Draw the architecture: DOT in the rqt_graph look (nodes ellipses, topics boxes), SVG, or Mermaid."""
    fmt = picture_format_for(picture_format, output)
    system = load(list(files), sources)
    write_pictures([draw([picture(system)], fmt, force)], fmt, output)


@click.command("graph-plan")
@click.argument("old")
@click.argument("new")
@picture_format_option
@click.option("--steps", "each_step", is_flag=True,
              help="one picture per step instead of one annotated picture of the whole plan")
@click.option("--strategy", type=click.Choice(STRATEGIES), default="default", show_default=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="write to a file (with --steps and dot or svg: FILE-01.EXT, FILE-02.EXT, …, and the "
                   "numbered files of an earlier, longer plan removed)")
@force_option
@guarded("graph")
def graph_plan(old: str, new: str, picture_format: Optional[str], each_step: bool, strategy: str,
               output: Optional[str], force: bool, sources: Sources,
               output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Draw the migration plan from OLD to NEW (paths or git:REF:PATH): created green, degraded
    orange, removed red; one annotated picture, or one per step with --steps."""
    fmt = picture_format_for(picture_format, output)
    with revisions() as revs:
        a, b = load([path_to_load(old, revs)], sources), load([path_to_load(new, revs)], sources)
    try:
        with status("planning…"):
            p = plan_change(a, b, strategy, Fallback())
    except NoSafePlan as e:
        raise Failure([Diagnostic("RC501", Severity.ERROR, "no safe migration plan to draw", b.span,
                                  notes=tuple(e.reasons))], EXIT_UNSAFE) from None
    pics = step_pictures(p) if each_step else [plan_picture(p)]
    if not pics:
        pics = [plan_picture(p, f"{b.name}: nothing to do")]
    numbered = bool(each_step and output and fmt in ("dot", "svg"))
    texts = [draw([pic], fmt, force) for pic in pics] if numbered else [draw(pics, fmt, force)]
    write_pictures(texts, fmt, output, numbered)
