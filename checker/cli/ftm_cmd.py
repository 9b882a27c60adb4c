"""`reconf ftm select|expand` and `reconf plan transition`.

Register with `main.add_command(ftm_group)` and `plan.add_command(transition_cmd)`. This
module imports `checker.cli.main` only when a command runs, since `checker.cli.main` imports it to
register the commands.
"""
from __future__ import annotations

import json
import os
import sys
from typing import Any, Optional

import click

from checker.cli.common import EXIT_BAD_INPUT, EXIT_OK, EXIT_UNSAFE, Failure, console, guarded, write_atomically
from checker.cli.plan_cmd import default_files, run
from checker.cli.plan_options import with_common
from checker.ftm.alloy_rules import alloy_profiles
from checker.ftm.expand import expand, to_text
from checker.ftm.library import compose
from checker.ftm.select import Candidate, profile, select
from checker.ftm.transition import parse_ftm, plan_transition, refuse_invalid_ftm, with_ftm
from checker.reports.pictures import picture
from checker.reports.report import OutputFormat
from codegen.graph import to_dot
from reconf_dsl.diagnostics import error
from reconf_dsl.loader import Sources, load
from reconf_dsl.span import Span
from reconf_dsl.words import plural

__all__ = ["ftm_group", "transition_cmd"]

format_option = click.option("--output-format", "output_format", type=click.Choice([f.value for f in OutputFormat]),
                             default="text", show_default=True, callback=lambda c, p, v: OutputFormat(v))


def _files(files: tuple[str, ...]) -> list[str]:
    return list(files) or default_files()


@click.group("ftm")
def ftm_group() -> None:
    """Fault-tolerance mechanisms: PBR, LFR, TR, AD (assertion & duplex), SEC, and their nesting.

    \b
    Compose outermost first: SEC(PBR(TR)) — SEC outside a duplex (PBR, LFR, AD), outside TR.
    """


@ftm_group.command("select")
@click.argument("component")
@click.option("-f", "--file", "files", multiple=True, type=click.Path(dir_okay=False),
              help="the architecture (repeatable; default: the one *.arch here, or $RECONF_ARCH)")
@click.option("--alloy/--no-alloy", "use_alloy", default=True, show_default=True,
              help="also judge every composition in the Alloy Analyzer; the two must agree")
@format_option
@guarded("ftm select")
def select_cmd(component: str, files: tuple[str, ...], use_alloy: bool, output_format: OutputFormat,
               sources: Sources) -> None:
    """List the FTMs and compositions valid for COMPONENT's faults, application and resources,
    cheapest first (CPUs, bandwidth, nodes), and why each other one is ruled out."""
    system = load(_files(files), sources)
    comp = system.component(component)
    if comp is None:
        raise Failure([error("RC103", f"no component '{component}'", system.span)])
    prof = profile(system, comp)
    cands = select(prof)
    alloy: dict[str, Any] = {}
    if use_alloy:
        verdict = alloy_profiles({component: prof}, {})
        mine = {str(c.composition) for c in cands if c.valid}
        theirs = set(verdict.valid[component])
        alloy = {"engine": "alloy", "agrees": mine == theirs, "seconds": round(verdict.seconds, 3)}
        if mine != theirs:
            raise Failure([error("RC499", f"Python and Alloy disagree on {component}: only Python: "
                                          f"{sorted(mine - theirs)}, only Alloy: {sorted(theirs - mine)}",
                                 comp.span)], EXIT_BAD_INPUT)
    attached = str(compose(comp.ftm.expr)[0] or comp.ftm.expr) if comp.ftm is not None else None
    valid = [c for c in cands if c.valid]
    if output_format is OutputFormat.JSON:
        click.echo(json.dumps({"format_version": 1, "tool": "reconf", "command": "ftm select",
                               "component": component, "attached": attached,
                               "profile": {"faults": sorted(prof.faults), "application": sorted(prof.application),
                                           "bandwidth": prof.bandwidth, "cpus": prof.cpus},
                               "valid": [c.to_dict() for c in valid],
                               "rejected": [c.to_dict() for c in cands if not c.valid], "evidence": alloy}, indent=2))
    else:
        _show(component, prof, cands, attached, alloy)
    sys.exit(EXIT_OK if valid else EXIT_UNSAFE)


def columns(rows: list[list[str]], right: frozenset[int] = frozenset()) -> list[str]:
    """Rows of cells as lines whose columns line up (two spaces between; `right`: the columns
    aligned on the right, numbers)."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join(c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))).rstrip()
            for r in rows]


def _show(component: str, prof: Any, cands: list[Candidate], attached: Optional[str], alloy: dict[str, Any]) -> None:
    from rich.markup import escape

    out = console()
    said = lambda xs: ", ".join(sorted(xs)) or "none declared"  # noqa: E731
    out.print(f"[bold]{component}[/]: faults {said(prof.faults)}; application {said(prof.application)}; "
              f"bandwidth {prof.bandwidth or 'unconstrained'}; CPUs {prof.cpus if prof.cpus is not None else 'unconstrained'}")
    valid = [c for c in cands if c.valid]
    out.print(f"\n[bold]Valid[/] ({len(valid)}), cheapest first:" if valid else "\n[bold red]No valid FTM[/]")
    if valid:
        rows = [["", "FTM", "covers", "CPUs", "bandwidth", "nodes"]]
        rows += [[f"{i}.", str(c.composition), ", ".join(sorted(c.composition.covers)), str(c.composition.cpus),
                  c.composition.bandwidth, str(c.cost[2])] for i, c in enumerate(valid, 1)]
        lines = columns(rows, frozenset({0, 3, 5}))
        out.print("  " + escape(lines[0]), style="dim")
        for line, c in zip(lines[1:], valid):
            mark = "  [green](attached)[/]" if attached == str(c.composition) else ""
            out.print("  " + escape(line) + mark)
    out.print(f"\n[bold]Ruled out[/] ({len(cands) - len(valid)}):")
    ruled = [c for c in cands if not c.valid]
    if ruled:
        lines = columns([["✗", str(c.composition), "; ".join(r.text for r in c.reasons)] for c in ruled])
        for line, c in zip(lines, ruled):
            mark = "  [red](attached)[/]" if attached == str(c.composition) else ""
            out.print("  " + escape(line) + mark)
    if alloy:
        out.print(f"\n[bold]Verification:[/] [green]✓[/] Alloy agrees ({alloy['seconds']:.2f} s)")


@ftm_group.command("expand")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--format", "picture_format", type=click.Choice(["dsl", "dot", "both"]), default=None,
              help="the expanded architecture as DSL text, as DOT, or both (DSL first)  "
                   "[default: what -o's extension says (.arch, .dot/.gv), else both]")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write to a file instead of stdout")
@guarded("ftm expand")
def expand_cmd(files: tuple[str, ...], picture_format: Optional[str], output: Optional[str], sources: Sources,
               output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Print FILES with every FTM expanded into its computation graph (Proxy, Protocol, Before,
    Proceed, After, crash detectors, Recovery, CA) as DSL text that re-parses, and as DOT."""

    picture_format = _expand_format(picture_format, output)
    system = load(list(files), sources)
    expanded, infos = expand(system)
    parts = []
    if picture_format in ("dsl", "both"):
        parts.append(to_text(expanded))
    if picture_format in ("dot", "both"):
        parts.append(to_dot(picture(expanded, title=f"{system.name} (FTMs expanded)")))
    text = "\n".join(parts)
    if output:
        write_atomically(output, text)
    else:
        click.echo(text, nl=False)
    n = sum(len(i.components) for i in infos)
    console().print(f"[green]✓[/] expanded {plural(len(infos), 'FTM')} into {plural(n, 'component')}"
                    + (f"; wrote {output}" if output else ""))
    sys.exit(EXIT_OK)


EXPAND_EXTENSIONS = {".arch": "dsl", ".dot": "dot", ".gv": "dot"}
_EXPAND_SAYS = {"dsl": "DSL text", "dot": "Graphviz DOT source", "both": "DSL text and DOT"}


def _expand_format(given: Optional[str], output: Optional[str]) -> str:
    """--format, or what -o's extension says (else both); a contradiction is RC013: DOT after the
    DSL in an .arch file would not parse back."""
    stem, ext = os.path.splitext(output or "")
    said = EXPAND_EXTENSIONS.get(ext.lower())
    if given is None:
        return said or "both"
    if said is not None and said != given:
        right = {"dsl": f"name the file {stem}.arch", "dot": f"name the file {stem}.dot",
                 "both": "name the file without .arch or .dot"}[given]
        raise Failure([error("RC013", f"-o {output} says {_EXPAND_SAYS[said]}, but --format {given} writes "
                                       f"{_EXPAND_SAYS[given]}; {right}, or leave out --format to write "
                                       f"{_EXPAND_SAYS[said]}", Span.unknown("<command line>"))])
    return given


@click.command("transition")
@click.argument("component")
@click.argument("new_ftm")
@click.option("--on", "hosts", help="hosts of the new FTM's replicas, comma-separated (default: as now)")
@click.option("--allow-invalid-ftm", is_flag=True,
              help="plan the transition even to an FTM the component's faults, characteristics or resources rule "
                   "out (the FTM rules, RC401-RC407, are then warnings on the plan)")
@with_common
@guarded("plan")
def transition_cmd(component: str, new_ftm: str, hosts: Optional[str], allow_invalid_ftm: bool, sources: Sources,
                   **opts: Any) -> None:
    """Change COMPONENT's FTM to NEW_FTM (`LFR`, `PBR(TR)`, `SEC(PBR(TR))`, `none`): a verified plan
    that keeps the nodes both graphs share, suspends each protocol while its neighbourhood is
    substituted and resumes it after; clients are never left unserved. An FTM the FTM rules rule out
    for COMPONENT is refused (exit 1, the rules named) unless --allow-invalid-ftm."""

    system = load(_files(opts["files"]), sources)
    expr = None if new_ftm.lower() == "none" else parse_ftm(new_ftm)
    on = tuple(h.strip() for h in hosts.split(",")) if hosts else None
    comp = system.component(component)
    old = str(comp.ftm.expr) if comp is not None and comp.ftm is not None else "none"
    holder: dict[str, Any] = {}
    if comp is not None and not allow_invalid_ftm:    # before planning: refused as `check` would judge it
        refuse_invalid_ftm(with_ftm(system, component, expr, on), component, expr)

    def make() -> Any:
        t = plan_transition(system, component, expr, on, opts["strategy"])
        holder["t"] = t
        return t.plan

    label = f"move {component} from {old} to {expr if expr is not None else 'none'}"
    expanded, _ = expand(system)
    run(label, expanded, make, sources, **opts)
