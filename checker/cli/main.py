"""The `reconf` command line. Human output goes to stderr through rich, machine output to stdout.

Exit codes: 0 safe / done, 1 unsafe / no safe plan, 2 bad input, usage, missing dependency,
resource failure or internal error; with `--detailed-exitcode`, `plan` and `gate` exit 3 for a safe
change that has steps (0 then means nothing to do). See docs/exit-codes.md."""
from __future__ import annotations

import sys
import time
from typing import Optional

import click

from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.loader import ALLOW_OUTSIDE_ENV, Sources, load
from reconf_dsl.words import agree

from checker.reports import formats, report
from checker.cli.common import (EXIT_OK, EXIT_UNSAFE, Failure, console, draw, emit_report, engine_option, files_argument, force_option,
                      format_option, guarded, picture_format_for, picture_format_option, plural, solver_option,
                      write_atomically, write_pictures)
from checker.model.config import Configuration
from checker.planning import STRATEGIES
from checker.cli.inputs import exclude_option, expand, nothing_left, paths_argument
from checker.reports.progress import status
from checker.cli.recording import bag_options, judge_bag, refuse_bag_options_alone
from checker.reports.report import OutputFormat, ReportFormat

@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="reconf")
@click.option("--allow-includes-outside", is_flag=True, envvar=ALLOW_OUTSIDE_ENV,
              help="follow includes that lead outside the directory tree of the file named "
                   "(env RECONF_ALLOW_INCLUDES_OUTSIDE=1)")
def main(allow_includes_outside: bool) -> None:
    """reconf: check ROS 2 architectures and plan safe run-time reconfigurations.

    \b
    Exit codes (docs/exit-codes.md): 0 safe or done, 1 unsafe or no safe plan,
                2 not answered: bad input, usage, a missing dependency, an output
                  that cannot be written, or an internal error,
                3 with --detailed-exitcode: a safe change with steps.
    """
    from reconf_dsl import loader
    loader.settings.allow_includes_outside = allow_includes_outside


@main.command()
@paths_argument
@exclude_option
@format_option
@engine_option
@solver_option
@bag_options
@guarded("check")
def check(files: tuple[str, ...], exclude: tuple[str, ...], output_format: ReportFormat, engine: str, solver: str,
          bag: Optional[str], window: float, tolerance: float, sources: Sources) -> None:
    """Prove that every functionality's assumptions hold in PATHs (one system; includes followed;
    a directory stands for the .arch files under it).

    Lists each assumption that does not hold with its chain: functionality → assumption →
    input → connector → each attached output and why it falls short. With --bag, also judges
    every rate and message type against a rosbag2 recording (docs/recordings.md).
    """
    from checker.alloy.engines import judge
    from checker.ftm.judge import judge_ftm

    refuse_bag_options_alone(bag)
    age = report.process_age()     # the interpreter's start-up and imports
    started = time.perf_counter() - age
    system = load(expand(files, exclude) or nothing_left(files), sources)
    parsed = time.perf_counter() - started - age
    with status(f"checking {system.name}" + (" in the Alloy Analyzer" if engine != "python" else "") + "…"):
        judged = judge(system, Configuration.initial(system), engine, solver)
        ftm, ftm_alloy = judge_ftm(system, engine)
    if ftm_alloy is not None:
        judged.engines.setdefault("alloy", {})["ftm_rules"] = ftm_alloy
    ev = judged.python
    diags = judged.warnings + ftm + [report.assumption_diagnostic(r) for r in ev.unsatisfied]
    safe = judged.valid and not any(d.is_error for d in ftm)
    rec = judge_bag(system, bag, window, tolerance)
    if rec is not None:
        diags += rec.diagnostics
        safe = safe and not rec.contradicted
    verdict = "safe" if safe else "unsafe"
    n, bad = len(ev.results), len(ev.unsatisfied)
    summary = ", ".join(plural(k, w) for k, w in ((len(system.components), "component"),
                                                    (len(system.connectors), "connector"), (n, "assumption")))
    how = judged.how()
    judging, details = judged.timing()
    parts = [("start-up", age), ("parsing", parsed)] + judging
    if ftm_alloy is not None:
        parts.append(("FTM rules in Alloy", ftm_alloy["seconds"]))
    if rec is not None:
        parts.append(("reading the recording", rec.seconds))
    wall = time.perf_counter() - started
    timing = ("; " + rec.summary if rec else "") + "; " + report.timing_note(wall, parts, details)
    # the engines' note (`how`) is about the assumptions; the FTM rules' is said after them
    by = ", judged by Alloy too" if ftm_alloy is not None else ""
    ftm_note = (f"; {plural(len(ftm), 'fault-tolerance finding')} (FTM rules{by})" if ftm else
                f"; FTM rules hold{by}" if any(c.ftm is not None for c in system.components) else "")
    if safe:
        line = f"{system.name} — {summary}, all hold{how}{ftm_note}{timing}"
        human = f"[bold green]✓ safe[/]: {line}"
    else:
        held = f"{bad} {agree(bad, 'does', 'do')} not hold" if bad else "all hold"
        line = f"{system.name} — {summary}, {held}{how}{ftm_note}{timing}"
        human = f"[bold red]✗ unsafe[/]: {line}"
    cases = report.assumption_cases(system.name, ev) + (rec.cases(system.name) if rec else [])
    rep = formats.Report("check", verdict, diags, cases, f"{verdict}: {line}")
    emit_report(rep, output_format, sources,
                lambda: report.document("check", verdict, diags, system=system.name, files=list(system.files),
                                        engines=judged.engines, timing=report.timing_json(wall, parts),
                                        assumptions=report.evaluation_json(ev),
                                        **({"recording": rec.doc} if rec else {})), human)
    sys.exit(EXIT_OK if safe else EXIT_UNSAFE)


@main.command("alloy")
@files_argument
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write the module here instead of stdout")
@guarded("alloy")
def alloy_cmd(files: tuple[str, ...], output: Optional[str], sources: Sources,
              output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Write the Alloy instance module of FILES' deployed configuration (open it in the Alloy GUI)."""
    from codegen.alloy import render_instance

    system = load(list(files), sources)
    text, _ = render_instance(system, Configuration.initial(system))
    if output:
        write_atomically(output, text)
        console().print(f"wrote {output}: `run Verdict` shows the configuration and what fails")
    else:
        click.echo(text, nl=False)


@main.command()
@files_argument
@picture_format_option
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write to a file instead of stdout")
@force_option
@guarded("graph")
def graph(files: tuple[str, ...], picture_format: Optional[str], output: Optional[str], force: bool,
          sources: Sources, output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Draw the architecture: DOT in the rqt_graph look (nodes ellipses, topics boxes), SVG, or Mermaid."""
    from checker.reports.pictures import picture
    fmt = picture_format_for(picture_format, output)
    system = load(list(files), sources)
    write_pictures([draw([picture(system)], fmt, force)], fmt, output)


@main.command("graph-plan")
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
    from checker.gate.revisions import path_to_load, revisions
    from checker.reports.pictures import plan_picture, step_pictures
    from checker.ftm.change import plan_change
    from checker.planning import Fallback, NoSafePlan
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


def _register() -> None:
    from checker.cli.bringup import down_cmd, up_cmd
    from checker.cli.discover import discover_cmd
    from checker.cli.drift import drift_cmd
    from checker.cli.fmt import fmt_cmd
    from checker.cli.ftm import ftm_group, transition_cmd
    from checker.cli.gate import gate_cmd
    from checker.cli.modes import modes_group
    from checker.cli.plan import plan
    from checker.cli.recover import recover_cmd
    plan.add_command(transition_cmd)
    main.add_command(plan)
    main.add_command(recover_cmd)
    main.add_command(up_cmd)
    main.add_command(down_cmd)
    main.add_command(gate_cmd)
    main.add_command(ftm_group)
    main.add_command(fmt_cmd)
    main.add_command(modes_group)
    main.add_command(discover_cmd)
    main.add_command(drift_cmd)
    try:
        from checker.cli.verify_model import verify_model_cmd
    except ImportError:  # pragma: no cover - the Alloy side is part of the package
        return
    main.add_command(verify_model_cmd, "verify-model")


_register()
