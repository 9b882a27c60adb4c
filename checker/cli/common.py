"""What every command shares: exit codes, `Failure` and `guarded` (every failure a diagnostic
and an exit code, never a traceback), the common options, output, atomic writes and pictures.
Each command module imports this, and `checker.cli.main` imports the command modules to register
them: imports go one way (docs/exit-codes.md for the codes)."""
from __future__ import annotations

import functools
import json
import os
import secrets
import sys
from typing import Any, Callable, Optional, TypeVar

import click
from rich.console import Console

from checker.alloy.bridge import DEFAULT_SOLVER, FALLBACK_SOLVER, SOLVER_NAMES  # the one table of solvers
from checker.alloy.engines import Engine, EnginesDisagree, EngineUnavailable
from checker.alloy.errors import AlloyUnavailable
from checker.ftm.expand import FtmRuleBroken
from checker.planning.plan import BadRequest
from checker.reports import formats, report
from checker.reports.pictures import (
    SVG_MAX_NODES,
    GraphvizUnavailable,
    format_of_output,
    largest,
    series,
    stale,
    to_svg,
)
from checker.reports.progress import status
from checker.reports.report import OutputFormat, ReportFormat
from codegen.graph import to_dot, to_mermaid
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Severity
from reconf_dsl.loader import Sources
from reconf_dsl.span import Span
from reconf_dsl.words import plural

EXIT_OK, EXIT_UNSAFE, EXIT_BAD_INPUT = 0, 1, 2
EXIT_CHANGES = 3          # only with --detailed-exitcode: a safe plan with at least one step
F = TypeVar("F", bound=Callable[..., Any])


def console() -> Console:
    return Console(stderr=True, highlight=False, soft_wrap=True)


class Failure(Exception):
    """Stop with these diagnostics and this exit code."""

    def __init__(self, diagnostics: list[Diagnostic], code: int = EXIT_BAD_INPUT):
        self.diagnostics, self.code = diagnostics, code


def guarded(command: str) -> Callable[[F], F]:
    """Turn every failure into rendered diagnostics and an exit code; never a traceback."""
    def wrap(fn: F) -> F:
        @functools.wraps(fn)
        def inner(*args: Any, **kwargs: Any) -> Any:
            fmt: OutputFormat | ReportFormat = kwargs.get("output_format", OutputFormat.TEXT)
            sources: Sources = kwargs.setdefault("sources", Sources())
            try:
                return fn(*args, **kwargs)
            except FtmRuleBroken as e:          # an unsafe architecture, as `check` judges it
                emit_failure(command, e.diagnostics, fmt, sources, verdict="unsafe")
                sys.exit(EXIT_UNSAFE)
            except DiagnosticError as e:
                emit_failure(command, e.diagnostics, fmt, sources)
                sys.exit(EXIT_BAD_INPUT)
            except Failure as e:
                emit_failure(command, e.diagnostics, fmt, sources)
                sys.exit(e.code)
            except (EngineUnavailable, EnginesDisagree) as e:
                emit_failure(command, [e.diagnostic], fmt, sources)
                sys.exit(EXIT_BAD_INPUT)
            except AlloyUnavailable as e:       # a missing or unstartable analyzer, wherever it was needed
                emit_failure(command, [Diagnostic("RC301", Severity.ERROR, str(e), Span.unknown("<alloy>"),
                                                  notes=("or use --no-alloy / --engine python",))], fmt, sources)
                sys.exit(EXIT_BAD_INPUT)
            except BadRequest as e:             # the user's mistake in what to plan: a usage error
                raise click.UsageError(str(e)) from None
            except KeyboardInterrupt:
                console().print("interrupted")
                sys.exit(130)
            except (click.exceptions.Exit, click.ClickException, SystemExit):
                raise
            except Exception as e:  # an internal error is still a clear message, not a traceback
                if os.environ.get("RECONF_DEBUG"):
                    raise
                emit_failure(command, [report.internal_error(f"internal error: {type(e).__name__}: {e}")],
                             fmt, sources)
                sys.exit(EXIT_BAD_INPUT)
        return inner  # type: ignore[return-value]
    return wrap


def emit_failure(command: str, diags: list[Diagnostic], fmt: OutputFormat | ReportFormat,
                 sources: Sources, verdict: str = "error") -> None:
    """The diagnostics of a command that stopped: `verdict` is "error" (exit 2) or "unsafe" (exit 1)."""
    if fmt.value == "json":
        click.echo(report.document(command, verdict, diags))
        return
    n = sum(1 for d in diags if d.is_error)
    summary = plural(n, "error")
    if fmt.value != "text":
        rep = formats.Report(command, verdict, diags, formats.failure_cases(command, diags), summary)
        click.echo(formats.render(rep, fmt.value), nl=False)
    report.render_text(diags, sources, sys.stderr)
    console().print(f"[bold red]✗[/] {summary}")


def emit_report(rep: formats.Report, fmt: ReportFormat, sources: Sources, json_doc: Callable[[], str],
                human: str) -> None:
    """Machine formats on stdout; diagnostics and the one-line verdict `human` (rich markup) on stderr."""
    if fmt is ReportFormat.JSON:
        click.echo(json_doc())
        return
    if fmt is not ReportFormat.TEXT:
        click.echo(formats.render(rep, fmt.value), nl=False)
    report.render_text(rep.diagnostics, sources, sys.stderr)
    console().print(human)


format_option = click.option("--output-format", "output_format", type=click.Choice([f.value for f in ReportFormat]),
                             default="text", show_default=True, callback=lambda c, p, v: ReportFormat(v),
                             help="text for people (stderr); json, sarif (2.1.0), github (workflow annotations) "
                                  "or junit (XML) on stdout")
files_argument = click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))


engine_option = click.option("--engine", type=click.Choice([e.value for e in Engine]), default=Engine.BOTH.value,
                             callback=lambda c, p, v: Engine(v),
                             show_default=True,
                             help="both: Alloy proves, Python explains, and they must agree")

def _solver_option(**shown: Any) -> Any:
    return click.option("--solver", type=click.Choice(SOLVER_NAMES, case_sensitive=False), default=DEFAULT_SOLVER,
                        **shown)


solver_option = _solver_option(show_default=True, help=f"SAT solver for Alloy; a native one whose library does not "
                                                      f"load here falls back to {FALLBACK_SOLVER}")
# `check` and `gate` evaluate in Alloy (a configuration, a plan), with nothing to solve: they
# take --solver (as they did when they solved) so that scripts passing it keep working, and
# do not show it
solver_option_unused = _solver_option(hidden=True, help="no effect: Alloy evaluates here, with nothing to solve")




class CannotWrite(Failure):
    """An output that cannot be written: RC007 at the path the user gave, exit 2."""


def read_run_report(path: str, need: str, what: str) -> dict[str, Any]:
    """The run report at `path` (written by `--report` of a plan script, `reconf up`, `down` or
    `recover`, or on any failure), which must have `need`; else a usage error (exit 2) saying
    it is not `what`."""
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise click.UsageError(f"{path}: cannot read it as a run report ({e})") from None
    if not isinstance(doc, dict) or doc.get("kind") != "run-report" or not doc.get(need):
        raise click.UsageError(f"{path}: not {what}")
    return doc


def write_atomically(path: str, text: str, newline: str = "\n") -> None:
    """Write next to the target, then rename: never a half-written file. Each "\\n" of `text` is
    written as `newline`. A symbolic link is written through (the link stays a link); a new file
    gets the mode the umask leaves of 0o666, an existing one keeps its mode. A failure is
    `CannotWrite`, naming `path` (not the temporary file)."""
    given, path = path, os.path.realpath(path)
    tmp = ""
    try:
        fd, tmp = _create_beside(path)
        with os.fdopen(fd, "w", encoding="utf-8", newline=newline) as f:
            f.write(text)
        if os.path.exists(path):
            os.chmod(tmp, os.stat(path).st_mode & 0o777)
        os.replace(tmp, path)
    except OSError as e:
        raise CannotWrite([Diagnostic("RC007", Severity.ERROR, f"cannot write {given}: {e.strerror or e}",
                                      Span.unknown(given))]) from None
    finally:
        if tmp and os.path.exists(tmp):
            os.unlink(tmp)


def _create_beside(path: str) -> tuple[int, str]:
    """A new empty file next to `path`, made as open(2) makes files: mode 0o666 less the umask
    (tempfile.mkstemp would make it 0o600 whatever the umask)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    while True:
        tmp = os.path.join(os.path.dirname(path), f".reconf-{secrets.token_hex(8)}")
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue


PICTURE_FORMATS = ["dot", "svg", "mermaid", "markdown"]
picture_format_option = click.option(
    "--format", "picture_format", type=click.Choice(PICTURE_FORMATS), default=None,
    help="dot (Graphviz source), svg (through Graphviz `dot`), mermaid, or markdown (Mermaid in a fenced block, "
         "for pull-request comments)  [default: what -o's extension says (.dot/.gv, .svg, .mmd, .md), else dot]")
force_option = click.option(
    "--force", is_flag=True,
    help="draw SVG however large the picture (Graphviz can take minutes beyond a few hundred nodes)")


def picture_format_for(picture_format: Optional[str], output: Optional[str]) -> str:
    """--format, or what -o's extension says; a contradiction between them is RC013."""
    try:
        return format_of_output(picture_format, output)
    except ValueError as e:
        raise Failure([Diagnostic("RC013", Severity.ERROR, str(e), Span.unknown("<command line>"))]) from None


def draw(pics: list[Any], picture_format: str, force: bool = False) -> str:
    """Pictures as one text: DOT graphs one after the other, SVG documents, or Mermaid blocks.
    SVG of a picture over SVG_MAX_NODES nodes is refused (RC012) unless `force`."""

    if picture_format == "mermaid" and len(pics) == 1:
        return to_mermaid(pics[0])
    if picture_format in ("mermaid", "markdown"):
        return "\n".join((f"**{p.title}**\n\n" if len(pics) > 1 else "") + "```mermaid\n" + to_mermaid(p) + "```\n"
                         for p in pics)
    dots = [to_dot(p) for p in pics]
    if picture_format == "dot":
        return "".join(dots)
    nodes = largest(pics)
    if nodes > SVG_MAX_NODES and not force:
        raise Failure([Diagnostic(
            "RC012", Severity.ERROR,
            f"the picture has {nodes:,} nodes; Graphviz `dot` lays out up to {SVG_MAX_NODES} in seconds but takes minutes "
            "beyond a few hundred (over 10 at 1,000 components), so no SVG is drawn",
            Span.unknown("<graphviz>"),
            notes=("write the DOT source with --format dot and render it yourself (`dot -Tsvg`, or `sfdp -Tsvg` "
                   "for a large graph), draw it as --format mermaid, or pass --force to wait for `dot`",))])
    try:
        with status(f"drawing {nodes:,} nodes with Graphviz dot…") as say:
            out = []
            for i, d in enumerate(dots, 1):
                if len(dots) > 1:
                    say(f"drawing picture {i} of {len(dots)} ({nodes:,} nodes at most) with Graphviz dot…")
                out.append(to_svg(d))
        return "".join(out)
    except GraphvizUnavailable as e:
        raise Failure([Diagnostic("RC011", Severity.ERROR, str(e), Span.unknown("<graphviz>"),
                                  notes=("install Graphviz (e.g. `apt-get install graphviz` or `brew install graphviz`), "
                                         "or use --format dot, mermaid or markdown",))]) from None


def write_pictures(texts: list[str], picture_format: str, output: Optional[str], numbered: bool = False) -> None:
    """One text to stdout or OUTPUT. With `numbered` (a series, one picture per step) the texts go
    to OUTPUT's stem with -01, -02…, and files of an earlier, longer series there are removed."""
    if not output:
        click.echo("".join(texts) if picture_format in ("dot", "svg") else "\n".join(texts), nl=False)
        return
    if not numbered:
        write_atomically(output, "".join(texts) if picture_format in ("dot", "svg") else "\n".join(texts))
        console().print(f"wrote {output}")
        return
    names = series(output, len(texts))
    for name, text in zip(names, texts):
        write_atomically(name, text)
    console().print(f"wrote {names[0]}" + (f" … {names[-1]}" if len(names) > 1 else ""))
    removed = []
    for name in stale(output, names):
        try:
            os.unlink(name)
            removed.append(name)
        except OSError as e:
            console().print(f"[yellow]could not remove[/] {name}, a step file of an earlier plan: {e.strerror}")
    if removed:
        shown = ", ".join(removed) if len(removed) <= 3 else f"{removed[0]} … {removed[-1]}"
        console().print(f"removed {plural(len(removed), 'step file')} of an earlier, longer plan: {shown}")
