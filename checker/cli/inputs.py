"""The paths a command that reads architectures is given (`check`, `fmt`) → the .arch files it reads.

A directory stands for every `*.arch` file under it, recursively, in sorted order; hidden files and
directories (a name starting with `.`) are skipped, and symbolic links to directories are not
followed. `--exclude GLOB` drops every file the pattern matches: its path, a name in it, or a run of
names (`build`, `ftm/*.arch`, `examples/ftm`). `-` (standard input) is passed through as it is."""
from __future__ import annotations

import fnmatch
import os
from typing import Iterable, Iterator, NoReturn

import click

from reconf_dsl.diagnostics import DiagnosticError, error
from reconf_dsl.loader import STDIN
from reconf_dsl.span import Span

SUFFIX = ".arch"

paths_argument = click.argument("files", nargs=-1, required=True, type=click.Path(), metavar="PATH...")
exclude_option = click.option("--exclude", "exclude", multiple=True, metavar="GLOB",
                              help="leave out files whose path, a name in it or a run of names matches GLOB "
                                   "(repeatable)")


def expand(paths: Iterable[str], exclude: Iterable[str] = ()) -> list[str]:
    """Each file once (a link and its target are one), in the order given, directories replaced by
    the .arch files under them; files an `exclude` pattern matches left out. A directory with no
    .arch file is bad input."""
    patterns = [p for p in (_parts(x) for x in exclude) if p]
    out: list[str] = []
    seen: set[str] = set()
    for path in paths:
        if path != STDIN and os.path.isdir(path):
            found = sorted(_walk(path))
            if not found:
                raise DiagnosticError([error("RC007", f"no {SUFFIX} file under {path}", Span(path, 1, 1, 1, 1),
                                             notes=(f"a directory stands for the {SUFFIX} files under it; "
                                                    "hidden ones are skipped",))])
        else:
            found = [path]
        for f in found:
            key = f if f == STDIN else os.path.realpath(f)  # a file and a link to it are one file
            if key in seen or (f != STDIN and excluded(f, patterns)):
                continue
            seen.add(key)
            out.append(f)
    return out


def excluded(path: str, patterns: list[list[str]]) -> bool:
    """Whether a pattern (split into names) matches the path, or a name or run of names in it."""
    parts = _parts(path)
    return any(len(pat) <= len(parts) and
               any(all(fnmatch.fnmatch(name, p) for name, p in zip(parts[i:i + len(pat)], pat))
                   for i in range(len(parts) - len(pat) + 1))
               for pat in patterns)


def _parts(path: str) -> list[str]:
    return [p for p in path.replace(os.sep, "/").split("/") if p not in ("", ".")]


def _walk(root: str) -> Iterator[str]:
    def refuse(e: OSError) -> None:
        where = e.filename or root
        raise DiagnosticError([error("RC007", f"cannot read directory {where}: {e.strerror}",
                                     Span(str(where), 1, 1, 1, 1))])

    for directory, dirs, files in os.walk(root, onerror=refuse):
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        for name in files:
            if name.endswith(SUFFIX) and not name.startswith("."):
                yield os.path.join(directory, name)


def nothing_left(paths: Iterable[str]) -> NoReturn:
    """For a command that needs a file: every one given was excluded."""
    first = next(iter(paths), "")
    raise DiagnosticError([error("RC007", "nothing to read: --exclude left out every file given",
                                 Span(first, 1, 1, 1, 1))])
