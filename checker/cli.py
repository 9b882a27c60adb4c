"""The `reconf` command line. Human output goes to stderr through rich, machine output to stdout.

Exit codes: 0 safe / done, 1 unsafe / no safe plan, 2 bad input, usage, missing dependency,
resource failure or internal error; with `--detailed-exitcode`, `plan` and `gate` exit 3 for a safe
change that has steps (0 then means nothing to do). See docs/exit-codes.md."""
from __future__ import annotations

import functools
import os
import secrets
import sys
import time
from typing import Any, Callable, Optional, TypeVar

import click
from rich.console import Console

from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Severity
from reconf_dsl.loader import ALLOW_OUTSIDE_ENV, Sources, load
from reconf_dsl.span import Span

from . import formats, report
from .config import Configuration
from .alloy.bridge import DEFAULT_SOLVER, FALLBACK_SOLVER, SOLVER_NAMES   # the one table of solvers
from .alloy.errors import AlloyUnavailable
from .engines import EngineUnavailable, EnginesDisagree
from .ftm.expand import FtmRuleBroken
from .planning import STRATEGIES
from .planning.plan import BadRequest
from .inputs import exclude_option, expand, nothing_left, paths_argument
from .progress import status
from .report import OutputFormat, ReportFormat

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
    summary = report.plural(n, "error")
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


engine_option = click.option("--engine", type=click.Choice(["both", "alloy", "python"]), default="both",
                             show_default=True,
                             help="both: Alloy proves, Python explains, and they must agree")

solver_option = click.option("--solver", type=click.Choice(SOLVER_NAMES, case_sensitive=False),
                             default=DEFAULT_SOLVER, show_default=True,
                             help=f"SAT solver for Alloy; a native one whose library does not load here "
                                  f"falls back to {FALLBACK_SOLVER}")


@main.command()
@paths_argument
@exclude_option
@format_option
@engine_option
@solver_option
@guarded("check")
def check(files: tuple[str, ...], exclude: tuple[str, ...], output_format: ReportFormat, engine: str, solver: str,
          sources: Sources) -> None:
    """Prove that every functionality's assumptions hold in PATHs (one system; includes followed;
    a directory stands for the .arch files under it).

    Lists each assumption that does not hold with its chain: functionality → assumption →
    input → connector → each attached output and why it falls short.
    """
    from .engines import judge, judge_ftm

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
    verdict = "safe" if safe else "unsafe"
    n, bad = len(ev.results), len(ev.unsatisfied)
    summary = ", ".join(plural(k, w) for k, w in ((len(system.components), "component"),
                                                    (len(system.connectors), "connector"), (n, "assumption")))
    how = judged.how()
    judging, details = judged.timing()
    parts = [("start-up", age), ("parsing", parsed)] + judging
    if ftm_alloy is not None:
        parts.append(("FTM rules in Alloy", ftm_alloy["seconds"]))
    wall = time.perf_counter() - started
    timing = "; " + report.timing_note(wall, parts, details)
    # the engines' note (`how`) is about the assumptions; the FTM rules' is said after them
    by = ", judged by Alloy too" if ftm_alloy is not None else ""
    ftm_note = (f"; {plural(len(ftm), 'fault-tolerance finding')} (FTM rules{by})" if ftm else
                f"; FTM rules hold{by}" if any(c.ftm is not None for c in system.components) else "")
    if safe:
        line = f"{system.name} — {summary}, all hold{how}{ftm_note}{timing}"
        human = f"[bold green]✓ safe[/]: {line}"
    else:
        held = f"{bad} {report.agree(bad, 'does', 'do')} not hold" if bad else "all hold"
        line = f"{system.name} — {summary}, {held}{how}{ftm_note}{timing}"
        human = f"[bold red]✗ unsafe[/]: {line}"
    rep = formats.Report("check", verdict, diags, report.assumption_cases(system.name, ev), f"{verdict}: {line}")
    emit_report(rep, output_format, sources,
                lambda: report.document("check", verdict, diags, system=system.name, files=list(system.files),
                                        engines=judged.engines, timing=report.timing_json(wall, parts),
                                        assumptions=report.evaluation_json(ev)), human)
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


plural = report.plural   # `1 assumption`, `3 assumptions`: for every command's counts


class CannotWrite(Failure):
    """An output that cannot be written: RC007 at the path the user gave, exit 2."""


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
    from .pictures import format_of_output
    try:
        return format_of_output(picture_format, output)
    except ValueError as e:
        raise Failure([Diagnostic("RC013", Severity.ERROR, str(e), Span.unknown("<command line>"))]) from None


def draw(pics: list[Any], picture_format: str, force: bool = False) -> str:
    """Pictures as one text: DOT graphs one after the other, SVG documents, or Mermaid blocks.
    SVG of a picture over SVG_MAX_NODES nodes is refused (RC012) unless `force`."""
    from codegen.graph import to_dot, to_mermaid

    from .pictures import SVG_MAX_NODES, GraphvizUnavailable, largest, to_svg
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
    from .pictures import series, stale
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


@main.command()
@files_argument
@picture_format_option
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write to a file instead of stdout")
@force_option
@guarded("graph")
def graph(files: tuple[str, ...], picture_format: Optional[str], output: Optional[str], force: bool,
          sources: Sources, output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Draw the architecture: DOT in the rqt_graph look (nodes ellipses, topics boxes), SVG, or Mermaid."""
    from .pictures import picture
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
    from .gate import resolve, revisions
    from .pictures import plan_picture, step_pictures
    from .planning import Fallback, NoSafePlan, plan_migrate
    fmt = picture_format_for(picture_format, output)
    with revisions() as revs:
        a, b = load([resolve(old, revs)], sources), load([resolve(new, revs)], sources)
    try:
        with status("planning…"):
            p = plan_migrate(a, b, strategy, fallback=Fallback())
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
    from .fmt_cli import fmt_cmd
    from .ftm.cli import ftm_group, transition_cmd
    from .gate import gate_cmd
    from .plan_cli import plan
    from .recover_cli import recover_cmd
    plan.add_command(transition_cmd)
    main.add_command(plan)
    main.add_command(recover_cmd)
    main.add_command(gate_cmd)
    main.add_command(ftm_group)
    main.add_command(fmt_cmd)
    try:
        from .verify_model import verify_model_cmd
    except ImportError:  # pragma: no cover - the Alloy side is part of the package
        return
    main.add_command(verify_model_cmd, "verify-model")


_register()
