"""`reconf gate --base OLD --head NEW`: a CI gate for architecture changes (the judgement is
`checker.gate.change`; OLD, NEW and the policy may be `git:REF:PATH`: `checker.gate.revisions`).
Every `--report FORMAT=FILE` is written from the same run; on bad input each still holds a valid
document that says why nothing was judged."""
from __future__ import annotations

import os
import sys
from dataclasses import replace
from typing import Callable, Optional

import click

from checker.alloy.engines import Engine, EnginesDisagree, EngineUnavailable
from checker.cli.common import (
    EXIT_CHANGES,
    EXIT_OK,
    EXIT_UNSAFE,
    CannotWrite,
    Failure,
    emit_report,
    engine_option,
    format_option,
    guarded,
    plural,
    solver_option_unused,
    write_atomically,
)
from checker.gate.change import judge_change
from checker.gate.comment import comment, failure_comment
from checker.gate.policy import Policy, check_names, load_policy
from checker.gate.revisions import GIT_PREFIX, Revisions, path_to_load, rename_sources, revisions, split_ref
from checker.reports import formats, report
from checker.reports.report import ReportFormat
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, error
from reconf_dsl.loader import Sources, display_path, load
from reconf_dsl.span import Span

REPORT_FORMATS = ("json", "sarif", "github", "junit", "markdown")


def parse_reports(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> list[tuple[str, str]]:
    out = []
    for v in values:
        fmt, sep, path = v.partition("=")
        if not sep or fmt not in REPORT_FORMATS or not path:
            raise click.BadParameter(f"'{v}' is not FORMAT=FILE with FORMAT one of {', '.join(REPORT_FORMATS)}")
        out.append((fmt, path))
    return out


def write_reports(reports: list[tuple[str, str]], render: Callable[[str], str]) -> list[Diagnostic]:
    """Each report `render`ed in its format and written (atomically); what could not be written."""
    failed = []
    for fmt, path in reports:
        try:
            write_atomically(path, render(fmt))
        except CannotWrite as e:
            why = e.diagnostics[0].message.removeprefix(f"cannot write {path}: ")
            failed.append(error("RC511", f"cannot write the {fmt} report {path}: {why}",
                                Span.unknown("<command line>")))
    return failed


class ReportsNotWritten(Failure):
    """Some `--report` files could not be written (RC511); the others hold the gate's verdict."""


def write_failure_reports(reports: list[tuple[str, str]], diags: list[Diagnostic], base: str, head: str) -> None:
    """Bad input: every report file still holds a valid document, which says why nothing was judged."""
    summary = plural(sum(1 for d in diags if d.is_error), "error")

    def render(fmt: str) -> str:
        if fmt == "json":
            return report.document("gate", "error", diags, base=base, head=head) + "\n"
        if fmt == "markdown":
            return failure_comment(base, head, diags)
        return formats.render(formats.Report("gate", "error", diags, formats.failure_cases("gate", diags), summary),
                              fmt)

    for d in write_reports(reports, render):
        click.echo(f"reconf gate: {d.message}", err=True)



@click.command("gate")
@click.option("--base", "base", required=True, metavar="OLD",
              help="the deployed architecture: a path or git:REF:PATH (e.g. git:origin/main:robot.arch)")
@click.option("--head", "head", required=True, metavar="NEW", help="the proposed architecture: a path or git:REF:PATH")
@click.option("--policy", "policy_file", metavar="FILE",
              help="policy TOML, a path or git:REF:PATH (default: reconf.toml, or [tool.reconf] in pyproject.toml, "
                   "found from here)")
@click.option("--allow-unsafe-base", is_flag=True,
              help="when OLD is not safe (no plan from it exists), pass a safe NEW alone, with a warning: the fix "
                   "must be deployed by other means")
@click.option("--allow-invalid-ftm", is_flag=True,
              help="judge NEW without the FTM rules (RC402-RC407: an FTM its component's faults, characteristics or "
                   "resources rule out), which become warnings, as `plan transition --allow-invalid-ftm` does")
@click.option("--detailed-exitcode", is_flag=True,
              help="exit 0 when there is nothing to do, 3 when the change is safe and has steps (1 fail, 2 bad input)")
@click.option("--report", "reports", multiple=True, metavar="FORMAT=FILE", callback=parse_reports,
              help="also write the report as FORMAT (json, sarif, github, junit, markdown: a pull-request comment) "
                   "to FILE; repeatable, so that one run writes every output CI needs")
@format_option
@engine_option
@solver_option_unused
@guarded("gate")
def gate_cmd(base: str, head: str, policy_file: Optional[str], allow_unsafe_base: bool, allow_invalid_ftm: bool,
             detailed_exitcode: bool,
             reports: list[tuple[str, str]], output_format: ReportFormat, engine: Engine, solver: str,
             sources: Sources) -> None:
    """Pass when NEW is safe and a verified migration plan from OLD to NEW exists within the policy.

    \b
    Policy keys ([tool.reconf] in pyproject.toml, or reconf.toml):
      max-disruption = N        Σ criticality × steps degraded, at most N
      max-degraded-seconds = S  Σ criticality × seconds degraded, as the plan expects, at most S
      never-degrade = [...]     COMPONENT.FUNCTIONALITY or FUNCTIONALITY never degraded
      keep-ftm = true | [...]   faults covered by these components' (or FTMs') mechanisms stay covered
      strategy = "default"      planning strategy
      allow-unsafe-base = true  as --allow-unsafe-base
    Every name must name something in NEW or OLD (RC508).
    Exit codes: 0 pass, 1 fail, 2 bad input; with --detailed-exitcode,
    0 nothing to do, 3 a safe change with steps.
    """
    del solver     # no effect on a gate (solver_option_unused)
    try:
        run_gate(base, head, policy_file, allow_unsafe_base, detailed_exitcode, reports, output_format, engine,
                 sources, allow_invalid_ftm)
    except ReportsNotWritten:
        raise                           # the reports that were written hold the verdict: keep them
    except (DiagnosticError, Failure) as e:
        write_failure_reports(reports, e.diagnostics, base, head)
        raise
    except (EngineUnavailable, EnginesDisagree) as e:
        write_failure_reports(reports, [e.diagnostic], base, head)
        raise
    except (click.exceptions.Exit, click.ClickException):
        raise
    except Exception as e:  # the guard reports it; the files must say so too
        if not os.environ.get("RECONF_DEBUG"):
            write_failure_reports(reports, [report.internal_error(f"internal error: {type(e).__name__}: {e}")],
                                  base, head)
        raise


def gate_policy(policy_file: Optional[str], revs: Revisions, sources: Sources) -> Policy:
    if policy_file is None or not policy_file.startswith(GIT_PREFIX):
        return load_policy(policy_file, sources=sources)
    path = path_to_load(policy_file, revs, includes=False)
    return load_policy(path, shown=revs.rename(display_path(path)), origin=split_ref(policy_file)[0],
                       sources=sources)


def run_gate(base: str, head: str, policy_file: Optional[str], allow_unsafe_base: bool, detailed_exitcode: bool,
             reports: list[tuple[str, str]], output_format: ReportFormat, engine: Engine,
             sources: Sources, allow_invalid_ftm: bool = False) -> None:
    with revisions() as revs:
        try:
            policy = gate_policy(policy_file, revs, sources)
            old = load([path_to_load(base, revs)], sources)
            new = load([path_to_load(head, revs)], sources)
            wrong = check_names(policy, old, new)
            if wrong:
                raise DiagnosticError(wrong)
        except DiagnosticError as e:
            rename_sources(sources, revs)
            raise DiagnosticError([revs.diagnostic(d) for d in e.diagnostics]) from None
        rename_sources(sources, revs)
        out = judge_change(old, new, policy, engine, allow_unsafe_base, allow_invalid_ftm)
        out.diagnostics = [revs.diagnostic(d) for d in out.diagnostics]
        out.cases = [replace(c, span=revs.span(c.span)) if c.span else c for c in out.cases]
    verdict = "pass" if out.passed else "fail"
    n = sum(1 for d in out.diagnostics if d.is_error)
    plan_line = f"; plan: {out.plan.summary()}" if out.plan is not None else ""
    if out.passed and out.plan is None:
        plan_line = "; the base is not safe: no plan from it, deploy by other means"
    line = f"{base} → {head}" + (f": {new.name} is safe{plan_line}, within {policy.where}" if out.passed else
                                 f": {plural(n, 'reason')}{plan_line}")
    human = f"[bold green]✓ gate passed[/] {line}" if out.passed else f"[bold red]✗ gate failed[/] {line}"
    rep = formats.Report("gate", verdict, out.diagnostics, out.cases, f"gate {verdict}: {line}")

    def json_doc() -> str:
        return report.document("gate", verdict, out.diagnostics, base=base, head=head, policy=policy.to_json(),
                               safe=out.safe, base_safe=out.base_safe, engines=out.engines, plan=out.plan_doc)

    def render(fmt: str) -> str:
        if fmt == "json":
            return json_doc() + "\n"
        if fmt == "markdown":
            summary = (f"{new.name} is safe, within {policy.where}" if out.passed else
                       f"{plural(n, 'reason')} the change does not pass")
            return comment(verdict=verdict, base=base, head=head, diagnostics=out.diagnostics, summary=summary,
                           plan=out.plan)
        return formats.render(rep, fmt)

    failed = write_reports(reports, render)
    if failed:
        raise ReportsNotWritten(failed)
    emit_report(rep, output_format, sources, json_doc, human)
    if not out.passed:
        sys.exit(EXIT_UNSAFE)
    sys.exit(EXIT_CHANGES if detailed_exitcode and not out.nothing_to_do else EXIT_OK)
