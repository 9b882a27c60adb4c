"""`reconf fmt PATH...`: rewrite .arch files in the canonical layout, every comment where it was.

The conventions of `ruff format` and `terraform fmt`: a directory stands for the .arch files under
it and `--exclude GLOB` leaves files out (checker/cli/inputs.py); `-` formats standard input onto
standard output; a symbolic link is written through and stays a link; each file keeps its line
endings (CRLF or LF, as its first line ends; a file that mixes them gets that one throughout) and
its byte-order mark; a file that cannot be read or parsed is reported, and the others are formatted
all the same. Includes are not followed.

Exit 0 when done, 1 when `--check` or `--diff` finds a file that would change, 2 when a file could
not be read, parsed or written (2 wins over 1)."""
from __future__ import annotations

import difflib
import sys
from dataclasses import dataclass

import click

from checker.cli.common import EXIT_BAD_INPUT, EXIT_UNSAFE, CannotWrite, Failure, console, guarded, write_atomically
from checker.cli.inputs import exclude_option, expand, paths_argument
from checker.reports.report import OutputFormat
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError
from reconf_dsl.formatter import format_document
from reconf_dsl.loader import STDIN, Sources, display_path, read_source
from reconf_dsl.parser import parse_text

BOM = "\ufeff"


@dataclass(frozen=True)
class Source:
    """One file as read: its text as it is and with every CRLF made LF (what is parsed)."""

    path: str
    shown: str
    text: str
    normal: str
    newline: str  # how its first line ends, "\r\n" or "\n"
    bom: bool

    def written(self, formatted: str) -> str:
        """`formatted` (LF) with this file's line endings: what the file holds when it is formatted."""
        return formatted.replace("\n", self.newline)


def read(path: str, sources: Sources) -> Source:
    text = read_source(path, sources)
    shown = display_path(path)
    first = text.find("\n")
    newline = "\r\n" if first > 0 and text[first - 1] == "\r" else "\n"
    normal = text.replace("\r\n", "\n")
    sources.texts[shown] = normal  # for diagnostics' snippets
    return Source(path, shown, text, normal, newline, path != STDIN and _starts_with_bom(path))


def _starts_with_bom(path: str) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(3) == BOM.encode("utf-8")
    except OSError:
        return False


@click.command("fmt")
@paths_argument
@exclude_option
@click.option("--check", "check_only", is_flag=True, help="change nothing; exit 1 if a file is not formatted")
@click.option("--diff", is_flag=True, help="change nothing; print what would change as a unified diff")
@click.option("--stdout", "to_stdout", is_flag=True, help="print the formatted text instead of writing the file")
@guarded("fmt")
def fmt_cmd(files: tuple[str, ...], exclude: tuple[str, ...], check_only: bool, diff: bool, to_stdout: bool,
            sources: Sources, output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Rewrite PATHs in the canonical layout, every comment where it was. Includes are not followed.

    A directory stands for the .arch files under it; `-` formats standard input onto standard
    output. Line endings (LF or CRLF) are kept, symbolic links written through. A file that cannot
    be parsed is reported and the others are formatted.

    \b
    Exit codes: 0 done, 1 a file would change (--check, --diff),
                2 a file could not be read, parsed or written.
    """
    failed: list[Diagnostic] = []
    unformatted: list[str] = []
    paths: list[str] = []
    for given in files:                 # a directory without .arch files is reported, and the rest formatted
        try:
            found = expand([given], exclude)
        except DiagnosticError as e:
            failed.extend(e.diagnostics)
            continue
        seen = set(paths)
        paths += [p for p in found if p not in seen]
    if not paths and not failed:
        console().print("[yellow]nothing to format[/]: --exclude left out every file given")
    for path in paths:
        try:
            src = read(path, sources)
            formatted = format_document(parse_text(src.normal, src.shown))
        except DiagnosticError as e:
            failed.extend(e.diagnostics)
            continue
        if to_stdout or (path == STDIN and not (check_only or diff)):
            _print(src.written(formatted))
            continue
        if src.written(formatted) == src.text:
            continue
        unformatted.append(src.shown)
        if diff:
            click.echo("".join(difflib.unified_diff(src.normal.splitlines(True), formatted.splitlines(True),
                                                    src.shown, src.shown + " (formatted)")), nl=False)
        elif not check_only:
            try:
                write_atomically(path, (BOM if src.bom else "") + formatted, newline=src.newline)
            except CannotWrite as e:
                failed.extend(e.diagnostics)
                continue
            console().print(f"formatted {src.shown}")
    if check_only or diff:
        for shown in unformatted:
            console().print(f"[yellow]would reformat[/] {shown}")
    if failed:
        raise Failure(failed, EXIT_BAD_INPUT)
    if (check_only or diff) and unformatted:
        sys.exit(EXIT_UNSAFE)


def _print(text: str) -> None:
    """As it is, as bytes: the line endings are the file's."""
    out = getattr(sys.stdout, "buffer", None)
    if out is None:  # a text-only stream, which makes its own line endings
        click.echo(text, nl=False)
        return
    sys.stdout.flush()
    out.write(text.encode("utf-8"))
    out.flush()
