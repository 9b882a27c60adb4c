"""`reconf verify-meta-model`: prove the six actions safe in the Alloy meta-model (or for every
size with z3), and show each command's outcome against its `expect`.

Exit codes: 0 all as expected, 1 some outcome differs, 2 Alloy or Java unavailable.
"""
from __future__ import annotations

import json
import sys
from typing import Any

import click

from checker.alloy import AlloyError, AlloyUnavailable
from checker.alloy.bridge import DEFAULT_SOLVER, FALLBACK_SOLVER, SOLVER_NAMES
from checker.alloy.metamodel import MAIN
from checker.alloy.verify_meta_model import PAPER_SCOPE, PAPER_SIGS, CommandRow, VerifyReport, verify_meta_model
from checker.cli.common import Failure, guarded
from checker.reports.report import OutputFormat
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.loader import Sources, read_source
from reconf_dsl.span import Span
from reconf_dsl.words import plural


def _render_text(report: VerifyReport, console: Any) -> None:
    from rich.table import Table

    table = Table(title=f"reconf meta-model (solver {report.solver})")
    for col in ("command", "scope", "outcome", "expected", "time"):
        table.add_column(col, justify="right" if col == "time" else "left")
    for r in report.rows:
        style = "" if r.as_expected is not False else "bold red"
        table.add_row(r.command, r.scope, r.outcome, r.expected, f"{r.seconds:.2f} s", style=style)
    console.print(table)
    for r in report.rows:
        if r.counterexample:
            _render_counterexample(r, console)
    for kind in ("check", "run"):
        alike: dict[tuple[tuple[str, str], ...], int] = {}
        for r in report.rows:
            if r.kind == kind:
                alike[tuple(r.bounds.items())] = alike.get(tuple(r.bounds.items()), 0) + 1
        for bounds, n in sorted(alike.items()):
            shown = ", ".join(f"{sig} {b}" for sig, b in bounds)
            console.print(f"atoms per signature in {plural(n, kind)}: {shown}")
    below = report.below_paper()
    console.print(f"the paper's scope (for {PAPER_SCOPE} of {', '.join(PAPER_SIGS)}; System: Pre and Post): "
                  + ("every check covers it" if not below else "[bold]NOT covered[/bold]: " + "; ".join(below)))
    verdict = "all as expected" if report.ok else "SOME OUTCOMES DIFFER FROM THEIR EXPECTATION"
    by = f" by {report.processes} processes" if report.processes > 1 else ""
    console.print(f"{plural(len(report.rows), 'command')}{by} in {report.wall:.1f} s (the commands' own: "
                  f"{report.total_seconds:.1f} s): {verdict}")


def _render_counterexample(r: CommandRow, console: Any) -> None:
    cex = r.counterexample
    assert cex is not None
    console.print(f"[bold]{r.command}[/bold] counterexample: action {cex.action}")
    for name, conf in (("before", cex.pre), ("after", cex.post)):
        console.print(f"  {name}:")
        console.print(f"    components present: {', '.join(conf.components) or '(none)'}")
        console.print(f"    degraded: {', '.join(conf.degraded) or '(none)'}")
        roles = "; ".join(f"{k}: {', '.join(ps)}" for k, ps in conf.roles.items())
        console.print(f"    roles: {roles or '(none)'}")
        if conf.unsatisfied:
            console.print(f"    unsatisfied: {', '.join(conf.unsatisfied)}")


@click.command("verify-meta-model")
@click.option("--scope", type=click.IntRange(1, 12), default=5, show_default=True,
              help="Scope of every check (runs use scope 3).")
@click.option("--solver", type=click.Choice(SOLVER_NAMES, case_sensitive=False), default=DEFAULT_SOLVER,
              show_default=True,
              help=f"SAT solver; a native one whose library does not load here falls back to {FALLBACK_SOLVER}.")
@click.option("--output-format", "output_format", type=click.Choice([f.value for f in OutputFormat]),
              default="text", show_default=True, callback=lambda c, p, v: OutputFormat(v))
@click.option("--model", "model_path", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Verify this meta-model file instead of the bundled one (its commands run "
                   "with the scopes written in it; --scope is ignored).")
@click.option("--unbounded", is_flag=True,
              help="Prove the six Safe assertions for every size with z3 instead (no Alloy; "
                   "--scope, --solver and --model are ignored).")
@guarded("verify-meta-model")
def verify_meta_model_cmd(scope: int, solver: str, output_format: OutputFormat, model_path: str | None,
                     unbounded: bool, sources: Sources) -> None:
    """Prove the six reconfiguration actions safe in the Alloy meta-model."""
    from rich.console import Console

    if unbounded:
        import checker.semantic_model.unbounded as z3proof  # z3 loads only for --unbounded: start-up time
        try:
            sys.exit(z3proof.command(output_format))
        except z3proof.Z3Unavailable as exc:
            raise Failure([Diagnostic("RC011", Severity.ERROR, str(exc), Span.unknown("<z3>"))]) from None

    console = Console(stderr=True)
    progress = console.is_terminal and output_format is OutputFormat.TEXT
    status = console.status("") if progress else None

    def before(label: str, n: int, total: int) -> None:
        if status is not None:
            status.update((f"[{n}/{total}] " if n else "") + f"{label} (scope {scope})…")

    def after(row: CommandRow) -> None:
        if progress:
            mark = "[green]✓[/green]" if row.as_expected is not False else "[red]✗[/red]"
            console.print(f"{mark} {row.command}: {row.outcome} in {row.seconds:.2f} s")

    modules = None
    if model_path is not None:
        modules = {MAIN: read_source(model_path, sources)}
    try:
        if status is not None:
            status.start()
        try:
            report = verify_meta_model(scope, solver, before, after, modules)
        finally:
            if status is not None:
                status.stop()
    except AlloyUnavailable as exc:
        raise Failure([Diagnostic("RC301", Severity.ERROR, f"Alloy unavailable: {exc}", Span.unknown("<alloy>"))]) \
            from None
    except AlloyError as exc:
        if model_path is None:
            raise Failure([Diagnostic("RC302", Severity.ERROR, f"Alloy rejected the meta-model: {exc}",
                                      Span.unknown("<alloy>"),
                                      notes=("this is a bug in reconf: please report it",))]) from None
        shown = next(reversed(sources.texts))
        where = Span(shown, exc.line, exc.column, exc.line, exc.column + 1) if exc.line else Span.unknown(shown)
        raise Failure([Diagnostic("RC302", Severity.ERROR, f"Alloy rejected the model: {exc.message}", where)]) \
            from None
    if output_format is OutputFormat.JSON:
        click.echo(json.dumps(report.to_json(), indent=2))
    else:
        _render_text(report, console)
    sys.exit(0 if report.ok else 1)


if __name__ == "__main__":
    verify_meta_model_cmd()
