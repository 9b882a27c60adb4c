"""`reconf modes export|import`: SMH model files of ROS 2 system_modes (docs/modes.md).

Exit 0 when written, 1 when `export` is refused because the deployed configuration is unsafe,
2 for bad input (RC621 not YAML, RC622 not an SMH model, with file:line:col) or an output that
cannot be written. Warnings (RC623 placeholders, RC624 what is not carried over) leave 0."""
from __future__ import annotations

import sys
from typing import Optional

import click

from checker.cli.common import (
    EXIT_OK,
    EXIT_UNSAFE,
    emit_failure,
    emit_report,
    files_argument,
    format_option,
    guarded,
    plural,
    write_atomically,
)
from checker.reality.smh.export import UnsafeDeployment, export, render
from checker.reality.smh.read import read_model
from checker.reality.smh.to_arch import to_arch
from checker.reports import formats, report
from checker.reports.report import ReportFormat
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl.diagnostics import Diagnostic, Severity, error
from reconf_dsl.loader import Sources, display_path, load, read_source
from reconf_dsl.span import Span

output_option = click.option("-o", "--output", type=click.Path(dir_okay=False),
                             help="write here (atomically) instead of stdout")


@click.group("modes")
def modes_group() -> None:
    """Exchange modes with ROS 2 system_modes (SMH model files): docs/modes.md."""


@modes_group.command("export")
@files_argument
@output_option
@click.option("--degrade-unsafe", is_flag=True,
              help="export an unsafe architecture all the same: its __DEFAULT__ mode degrades what must be "
                   "degraded for the configuration to be valid (RC625 warning instead of error)")
@format_option
@guarded("modes export")
def export_cmd(files: tuple[str, ...], output: Optional[str], degrade_unsafe: bool, output_format: ReportFormat,
               sources: Sources) -> None:
    """Write the SMH model file of FILES' deployed system: a node per component whose modes set its
    reconf.mode.<functionality> parameters, and a system whose modes are all safe configurations."""
    _needs_output(output_format, output)
    system = load(list(files), sources)
    try:
        exp = export(system, degrade_unsafe)
    except UnsafeDeployment:
        ev = evaluate(system, Configuration.initial(system))
        diags = [_unsafe(system.name, system.span, Severity.ERROR)] + [report.assumption_diagnostic(r)
                                                                         for r in ev.unsatisfied]
        emit_failure("modes export", diags, output_format, sources, verdict="unsafe")
        sys.exit(EXIT_UNSAFE)
    default = exp.modes[0]
    warns = [_unsafe(system.name, system.span, Severity.WARNING)] if default.degraded else []
    _write(render(exp, system), output)
    nodes = plural(len(exp.components), "node")
    line = f"{system.name} — {nodes}, {plural(len(exp.modes), 'system mode')}, each a valid configuration"
    _report("modes export", warns, line, output, output_format, sources)


@modes_group.command("import")
@click.argument("model", type=click.Path(dir_okay=False))
@output_option
@format_option
@guarded("modes import")
def import_cmd(model: str, output: Optional[str], output_format: ReportFormat, sources: Sources) -> None:
    """Write a starting-point architecture (.arch) from the SMH model file MODEL (`-` for stdin):
    a component per node, placeholders for what SMH does not say, system modes as comments."""
    _needs_output(output_format, output)
    shown = display_path(model)
    text = read_source(model, sources)
    sources.texts[shown] = text
    arch, warns = to_arch(read_model(text, shown))
    _write(arch, output)
    line = f"{shown} — {plural(len(warns), 'thing')} to fill in or not carried over (warnings)"
    _report("modes import", warns, line, output, output_format, sources)


def _unsafe(name: str, span: Span, severity: Severity) -> Diagnostic:
    if severity is Severity.ERROR:
        return error("RC625", f"{name} is not safe as deployed, so its __DEFAULT__ mode (every functionality "
                              "normal) would not be: nothing exported", span,
                     notes=("fix the architecture (`reconf check` explains it), or pass --degrade-unsafe",))
    return Diagnostic("RC625", severity, f"{name} is not safe as deployed: its __DEFAULT__ mode degrades what must "
                                         "be degraded (the YAML's comment says what and why)", span)


def _needs_output(output_format: ReportFormat, output: Optional[str]) -> None:
    if output_format is not ReportFormat.TEXT and not output:
        raise click.UsageError(f"--output-format {output_format.value} writes the report on stdout: "
                               "give -o for the file")


def _write(text: str, output: Optional[str]) -> None:
    if output:
        write_atomically(output, text)
    else:
        click.echo(text, nl=False)


def _report(command: str, warns: list[Diagnostic], line: str, output: Optional[str], fmt: ReportFormat,
            sources: Sources) -> None:
    """The warnings and the verdict line; machine formats on stdout (the file then went to -o)."""
    human = f"[green]✓[/] {'wrote ' + output + ': ' if output else ''}{line}"
    rep = formats.Report(command, "done", warns, [], line)
    emit_report(rep, fmt, sources, lambda: report.document(command, "done", warns, output=output), human)
    sys.exit(EXIT_OK)
