"""`reconf plan replace|remove|add|migrate`: plan, verify, show like `terraform plan`, emit a ROS 2 script;
`reconf plan verify`: verify a plan document from anywhere in both engines.

Every plan shown has been checked step by step by the Python engine; with Alloy available
(the default) it is also checked as a whole by the Alloy Analyzer before it is shown. A
strategy that finds no plan, or whose plan Alloy refutes, hands over to the next
(`checker.planning.chain`); the plan shown says which strategy produced it.
"""
from __future__ import annotations

import glob
import json
import os
import sys
from dataclasses import replace as dc_replace
from typing import Any, Callable, Optional, Sequence

import click
from rich.markup import escape

from checker.alloy.engines import Engine
from checker.cli.common import (
    EXIT_CHANGES,
    EXIT_OK,
    EXIT_UNSAFE,
    Failure,
    console,
    engine_option,
    guarded,
    plural,
    read_run_report,
    write_atomically,
)
from checker.cli.plan_options import with_common, with_plan_options
from checker.ftm.plan_change import has_ftm, plan_change, planned_on
from checker.gate.plan_verify import PlanJudgement, verify_plan
from checker.planning import Attempt, NoPlanFound, NoSafePlan, Plan, plan_add, plan_remove, plan_replace
from checker.planning.alloy_verify import alloy_evidence
from checker.planning.plan import BadRequest, degradation, unknown
from checker.planning.verified import plan_verified
from checker.reports import report
from checker.reports.plan_document import plan_document, with_model
from checker.reports.plan_reader import read_plan
from checker.reports.progress import status
from checker.reports.report import OutputFormat
from codegen.ros2 import FORMAT_VERSION, render_plan_script
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import System
from reconf_dsl.loader import Sources, display_path, load, read_source
from reconf_dsl.span import Span
from reconf_dsl.words import agree


def default_files() -> list[str]:
    env = os.environ.get("RECONF_ARCH")
    if env:
        return [env]
    found = sorted(glob.glob("*.arch"))
    if len(found) == 1:
        return found
    raise click.UsageError("say which architecture to plan on with -f FILE "
                           f"({'no' if not found else 'several'} .arch files here)")


@click.group()
def plan() -> None:
    """Plan a reconfiguration as a verified sequence of the six actions.

    \b
    Symbols: + create  - remove  → attach  × detach  ↓ degrade  ↑ upgrade
    """


@plan.command("replace")
@click.argument("component")
@click.option("--with", "replacement", help="the new version (default: the one declared `replaces COMPONENT`)")
@click.option("--from", "source", type=click.Path(dir_okay=False), help="take the new version from this file")
@with_common
@guarded("plan")
def replace_cmd(component: str, replacement: Optional[str], source: Optional[str], sources: Sources,
                **opts: Any) -> None:
    """Replace COMPONENT by a new version of it."""
    system = load(list(opts["files"]) or default_files(), sources)
    new: Any = replacement
    if source is not None:
        other = load([source], sources)
        name = replacement or component
        new = other.component(name)
        if new is None:
            raise unknown("component", name, [c.name for c in other.components + other.versions], source)
        if system.component(new.name) is not None:
            new = dc_replace(new, name=f"{new.name}@new")
    elif new is None:
        versions = [v.name for v in system.versions if v.replaces == component]
        if len(versions) != 1:
            if system.component(component) is None:
                raise unknown("deployed component", component, [c.name for c in system.components], system.name)
            raise BadRequest(f"{component} has {'no declared new version' if not versions else 'several: '}"
                             f"{', '.join(versions)}; say which with --with, or take one from a file with --from")
        new = versions[0]
    label = f"replace {component} with {new if isinstance(new, str) else new.name}"
    run(label, system, lambda fb: plan_replace(system, component, new, opts["strategy"], fallback=fb), sources,
        chain=True, **opts)


@plan.command("remove")
@click.argument("component")
@with_common
@guarded("plan")
def remove_cmd(component: str, sources: Sources, **opts: Any) -> None:
    """Remove COMPONENT, degrading what depends on it."""
    system = load(list(opts["files"]) or default_files(), sources)
    run(f"remove {component}", system, lambda fb: plan_remove(system, component, opts["strategy"], fallback=fb),
        sources, chain=True, **opts)


@plan.command("add")
@click.argument("component")
@click.option("--from", "source", required=True, type=click.Path(dir_okay=False),
              help="the file declaring COMPONENT and its attachments")
@with_common
@guarded("plan")
def add_cmd(component: str, source: str, sources: Sources, **opts: Any) -> None:
    """Add COMPONENT as declared in another file, with its attachments there."""
    system = load(list(opts["files"]) or default_files(), sources)
    other = load([source], sources)
    run(f"add {component}", system,
        lambda fb: plan_add(system, component, opts["strategy"], source=other, fallback=fb), sources, chain=True,
        **opts)


@plan.command("migrate")
@click.argument("old", type=click.Path(dir_okay=False))
@click.argument("new", type=click.Path(dir_okay=False))
@with_plan_options
@guarded("plan")
def migrate_cmd(old: str, new: str, sources: Sources, **opts: Any) -> None:
    """Move the deployed OLD architecture to NEW: any mix of added, removed, replaced and rewired
    components and changed guarantees."""
    a, b = load([old], sources), load([new], sources)
    label = f"migrate {os.path.basename(old)} → {os.path.basename(new)}"
    deployed, target = planned_on(a, b)
    run(label, deployed, lambda fb=None: plan_change(a, b, opts["strategy"], fb), sources, target=target,
        chain=not has_ftm(a, b), **opts)


@plan.command("verify")
@click.argument("plan_file", metavar="PLAN.json", type=click.Path(dir_okay=False))
@click.option("-f", "--file", "files", multiple=True, type=click.Path(dir_okay=False),
              help="the architecture the plan is on (repeatable; default: the one *.arch here, or $RECONF_ARCH)")
@engine_option
@click.option("--output-format", "output_format", type=click.Choice([f.value for f in OutputFormat]),
              default="text", show_default=True, callback=lambda c, p, v: OutputFormat(v))
@guarded("plan")
def verify_cmd(plan_file: str, files: tuple[str, ...], engine: Engine, output_format: OutputFormat,
               sources: Sources) -> None:
    """Verify the plan in PLAN.json (format 1 or 2 of docs/executor.md, from reconf, by hand or from
    another tool) on the architecture: every configuration well formed and valid, every step's
    preconditions met and the next configuration its effect, judged by the Python engine and by
    Alloy on their own. The first rule broken is shown where the document breaks it."""
    system = load(list(files) or default_files(), sources)
    doc = read_plan(display_path(plan_file), read_source(plan_file, sources), system)
    with status(f"verifying {plural(len(doc.steps), 'step')}{engine.says()}…"):
        judged = verify_plan(system, doc, engine)
    alloy = judged.engines.get("alloy", {})
    if alloy.get("verdict") == "not run":
        raise Failure([Diagnostic("RC303", Severity.ERROR, f"Alloy could not verify the plan: {alloy.get('reason')}",
                                  Span.unknown("<alloy>"), notes=("`--engine python` relies on the Python engine "
                                                                  "alone",))])
    verdicts = {name: e["valid"] for name, e in judged.engines.items()}
    if len(set(verdicts.values())) > 1:
        raise Failure([Diagnostic("RC300", Severity.ERROR, "the engines disagree on the plan: " + ", ".join(
            f"{name} says {'safe' if ok else 'unsafe'}" for name, ok in verdicts.items()), doc.step_spans[0]
            if doc.step_spans else Span.unknown(doc.file), notes=tuple(
                f"{name}: {e.get('reason') or 'every rule holds'}" for name, e in judged.engines.items()) + (
                "this is a bug in reconf: please report it with the plan and the .arch file",))])
    _show_verified(judged, output_format, sources)
    sys.exit(EXIT_OK if judged.safe else EXIT_UNSAFE)


def _show_verified(judged: PlanJudgement, fmt: OutputFormat, sources: Sources) -> None:
    doc = judged.plan
    if fmt is OutputFormat.JSON:
        click.echo(json.dumps({"format_version": FORMAT_VERSION, "tool": "reconf", "command": "plan verify",
                               "file": doc.file, "verdict": "safe" if judged.safe else "unsafe",
                               "steps": len(doc.steps), "states": len(doc.states), "engines": judged.engines,
                               "diagnostics": [report.diagnostic_json(d) for d in judged.diagnostics]}, indent=2))
        return
    report.render_text(judged.diagnostics, sources, sys.stderr)
    out = console()
    what = f"{doc.file}: {plural(len(doc.steps), 'step')}, {plural(len(doc.states), 'state')}"
    if judged.safe:
        out.print(f"[bold green]✓ verified[/]: {escape(what)}; every configuration well formed and valid, every step's "
                  f"preconditions hold and the next configuration is its effect ({_by(judged)})")
        return
    out.print(f"[bold red]✗ refused[/]: {escape(what)} ({_by(judged)})")
    alloy = judged.engines.get("alloy")
    if alloy:
        out.print(f"  Alloy: {escape(str(alloy.get('reason')))}")


def _by(judged: PlanJudgement) -> str:
    names = {"python": "the Python engine", "alloy": "Alloy"}
    return "judged by " + " and ".join(names[n] for n in judged.engines)


def run(label: str, system: System, make: Callable[..., Plan], sources: Sources, *, strategy: str,
        use_alloy: bool, output: Optional[str], output_format: OutputFormat, files: tuple[str, ...] = (),
        target: Optional[System] = None, engine: Engine = Engine.PYTHON, max_steps: int = 12,
        detailed_exitcode: bool = False, chain: bool = False, durations_from: Optional[str] = None,
        apply: Optional[Callable[[dict[str, Any]], int]] = None) -> None:
    """Plan, verify, show. With `chain`, `make` takes a `Fallback` and plans through
    `checker.planning.chain`: a strategy that finds no plan, or whose plan Alloy refutes, hands
    over to the next; otherwise `make()` plans alone and a refuted plan means no plan. With
    `apply` and no `output`, the verified plan's script document is handed to `apply`, whose
    answer is the exit status (`reconf up`, `reconf down`). With `durations_from`, the plan's
    seconds are estimated with what that run report timed (docs/soundness.md#seconds-on-the-wire)."""

    fmt = output_format
    report = read_run_report(durations_from, "timings", "a run report with timed steps") if durations_from else None
    with status("planning…") as say:
        def judge(p: Plan) -> dict[str, Any]:
            say(f"verifying the plan of the {p.strategy} strategy in the Alloy Analyzer ({len(p.states)} states)…")
            return alloy_evidence(p, progress=say)

        try:
            verified = plan_verified(make, use_alloy=use_alloy, chain=chain, judge=judge,
                                     alloy_planner=engine is Engine.ALLOY, max_steps=max_steps, progress=say)
        except NoPlanFound as e:
            return no_plan(label, e.reasons, fmt, attempts=e.attempts)
        except NoSafePlan as e:
            return no_plan(label, e.reasons, fmt)
    p, evidence = verified.plan, verified.evidence
    if report is not None and durations_from is not None:
        p.times = p.durations().observed(report, durations_from)
    if verified.not_run is not None:      # not answered: not "unsafe" (docs/exit-codes.md)
        raise Failure([Diagnostic("RC303", Severity.ERROR, f"Alloy could not verify the plan to {label}: "
                                  f"{verified.not_run}", Span.unknown("<alloy>"),
                                  notes=("`--no-alloy` relies on the Python engine's step-by-step "
                                         "verification alone",))])
    if verified.refuted is not None:
        return no_plan(label, [verified.refuted], fmt, p, evidence, attempts=p.attempts)
    doc = plan_document(label, system, p, evidence, target)
    if output or apply is not None:
        script_doc = with_model(doc, p)
        if output:
            write_atomically(output, render_plan_script(script_doc))
    if fmt is OutputFormat.JSON:
        click.echo(json.dumps(doc, indent=2))
    else:
        show(label, p, evidence, output)
    code = apply(script_doc) if apply is not None and not output else EXIT_OK
    sys.exit(EXIT_CHANGES if code == EXIT_OK and detailed_exitcode and p.steps else code)


STYLES = {"create": "green", "remove": "red", "attach": "cyan", "detach": "magenta", "degrade": "yellow",
          "upgrade": "blue"}


def list_steps(out: Any, p: Plan) -> None:
    """The plan's steps, numbered; with batches, each batch's steps marked ┌ │ └."""
    marks = {i: "┌" if i == a else "└" if i == b else "│" for a, b in p.batches for i in range(a, b + 1)}
    for i, a in enumerate(p.steps, 1):
        mark = f"{marks.get(i, ' ')} " if marks else ""
        out.print(f"  {i:>3}. {mark}[{STYLES[a.kind]}]{a.symbol}[/] {a.describe()}", markup=True)


def show(label: str, p: Plan, evidence: dict[str, Any], output: Optional[str]) -> None:
    out = console()
    after = ""
    if p.attempts:
        tried = [a.strategy for a in p.attempts]
        after = f"; {' and '.join([', '.join(tried[:-1]), tried[-1]] if len(tried) > 1 else tried)} failed, see below"
    out.print(f"reconf will {label} in {plural(len(p.steps), 'step')} (strategy [bold]{p.strategy}[/]{after}):\n")
    list_steps(out, p)
    counts: dict[str, int] = {}
    for a in p.steps:
        counts[a.kind] = counts.get(a.kind, 0) + 1
    deg = degradation(p)
    parts = ", ".join(f"{n} {k}" for k, n in counts.items()) or "nothing to do"
    out.print(f"\n[bold]Plan:[/] {plural(len(p.steps), 'action')} ({parts}); "
              f"{plural(len(deg['functionalities']), 'functionality', 'functionalities')} degraded; longest degradation "
              f"{plural(deg['longest'], 'step')}"
              + (f" ({deg['longest_functionality']})" if deg["longest_functionality"] else "") + ".")
    out.print(f"[bold]Disruption:[/] {p.disruption} (Σ criticality × steps degraded)")
    out.print(f"[bold]Time:[/] {seconds_line(p)}")
    al = _verification(out, evidence)
    if al:
        if al.get("slice"):
            sl = al["slice"]
            once = sl["judged_once"]
            if sl.get("windows", 1) > 1:
                where = (f"in {sl['windows']} windows of consecutive steps, each on the components it can "
                         f"affect (at most {sl['components']})")
                reads = f"{agree(once, 'reads', 'read')} nothing the first window changes"
            else:
                where, reads = f"on the {plural(sl['components'], 'component')} the plan can affect", \
                    f"{agree(once, 'reads', 'read')} nothing it changes"
            out.print(f"                ({where}; {agree(once, 'the 1 other', f'the other {once}')} {reads} and "
                      f"{agree(once, 'was', 'were')} judged once)")
        if al.get("lossless"):
            out.print(f"              [green]✓[/] Alloy: client side kept: {'; '.join(al['lossless'])} in every state")
        if al.get("batches"):
            b = al["batches"]
            ok = b["batches"] - len(b["refused"])
            out.print(f"              [green]✓[/] Alloy: {plural(ok, 'batch', 'batches')} of steps run together: "
                      f"{plural(b['states'], 'state')} some order reaches valid, {plural(b['moves'], 'move')} "
                      "instances of their actions")
    else:
        out.print("              [yellow]![/] Alloy verification skipped (--no-alloy)")
    for attempt in p.attempts:
        out.print(f"[dim]note: {escape(attempt.describe())}[/]")
    for note in p.notes:
        if note.startswith("warning: "):
            out.print(f"[yellow]{escape(note)}[/]")
        else:
            out.print(f"[dim]note: {escape(note)}[/]")
    if p.recovery is not None and not p.steps:
        ended = len(p.recovery.orphans)
        out.print("nothing to recover: the observed configuration is valid and is the target"
                  + (f" ({plural(ended, 'orphan')} of a plan to end)" if ended else ""))
    if output:
        out.print(f"Wrote {output}: run it with `python3 {output}` (or `--dry-run` to replay it without ROS).")


def seconds_line(p: Plan) -> str:
    """The plan's expected time on the wire and what stays degraded how long, most first."""
    sec = p.seconds()
    what = (f"degraded ~{sec.weighted:.2f} s (Σ criticality × seconds degraded of what served before: "
            f"{sec.longest()})" if sec.seconds else "nothing that served before is degraded")
    return (f"~{sec.total:.1f} s for the {plural(len(p.steps), 'step')}; {what}; "
            f"durations: {', '.join(p.durations().sources)}")


def _verification(out: Any, evidence: dict[str, Any]) -> Optional[dict[str, Any]]:
    """The lines saying how the plan was verified, by the Python engine and by Alloy (whose
    evidence is returned for the lines that follow)."""
    py = evidence["python"]
    states, restore = py["states"], py.get("restore", {}).get("steps", 0)
    if restore:
        out.print(f"[bold]Verification:[/] [green]✓[/] Python engine: {_restoring(restore)}, restoring validity; "
                  "each state fails only on what a later one degrades (RecoverDegrade, RecoverMonotone);")
        out.print(f"              from there every precondition holds, {plural(states - restore, 'state')} valid")
    else:
        out.print("[bold]Verification:[/] [green]✓[/] Python engine: every precondition holds, "
                  + (f"all {states} states valid" if states != 1 else "the 1 state is valid")
                  + (f"; in each of {plural(py['batches'], 'batch', 'batches')} of steps run together, in every order"
                     if py.get("batches") else ""))
    al = evidence.get("alloy")
    if al:
        out.print(f"              [green]✓[/] Alloy: {plural(al['states'], 'state')} valid, "
                  f"{plural(al['transitions'], 'transition')} "
                  f"{agree(al['transitions'], 'is an instance of its action', 'are instances of their actions')} "
                  f"(evaluated in {al['seconds']:.2f} s, {al['module_hash'][:19]})"
                  + (f", from the state after step {restore}" if restore else ""))
    return al


def _restoring(n: int) -> str:
    return "step 1 degrades what fails" if n == 1 else f"steps 1-{n} degrade what fails"


def no_plan(label: str, reasons: list[str], fmt: OutputFormat, p: Optional[Plan] = None,
            evidence: Optional[dict[str, Any]] = None, attempts: Sequence[Attempt] = ()) -> None:
    if fmt is OutputFormat.JSON:
        doc: dict[str, Any] = {"format_version": FORMAT_VERSION, "tool": "reconf", "command": "plan",
                               "operation": label, "verdict": "no-plan", "reasons": reasons,
                               "evidence": evidence or {}}
        if attempts:
            doc["attempts"] = [a.to_dict() for a in attempts]
        click.echo(json.dumps(doc, indent=2))
    else:
        out = console()
        out.print(f"[bold red]✗ no safe plan[/] to {label}:")
        for r in reasons:
            out.print(f"  - {r}", markup=False)
    sys.exit(EXIT_UNSAFE)


