"""The pre-commit hooks of `.pre-commit-hooks.yaml`, given the staged `.arch` files.

`python -m checker.cli.hooks check [--engine E] [--solver S] FILES…` checks the systems the files
belong to, each as `reconf check ROOT` would: every staged file that declares a `system`, and
every file of the repository (tracked or staged) that declares one and includes a staged file,
directly or through other includes. A staged file that only holds parts of a system is
checked through the systems that include it; one that no system includes is named and left
alone. The hook fails when one system does (exit 1 unsafe, 2 bad input).

`python -m checker.cli.hooks fmt FILES…` rewrites the files that are not in the canonical layout
(`reconf fmt`) and fails when it changed one, as formatter hooks do: stage the result and
commit again.
"""
from __future__ import annotations

import os
import subprocess
import sys
from typing import Optional

import click

from checker.alloy.engines import Engine
from checker.cli.common import EXIT_BAD_INPUT, EXIT_OK, EXIT_UNSAFE, console, engine_option, solver_option
from checker.cli.main import main as reconf
from reconf_dsl import ir
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.parser import parse_text
from reconf_dsl.words import plural


def repository_files(start: str) -> list[str]:
    """Every .arch file of the repository at `start` that is tracked or staged (absolute paths);
    outside a repository, every .arch file under `start`."""
    try:
        top = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=start, capture_output=True, text=True,
                             check=True).stdout.strip()
        listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--", "*.arch"], cwd=top, capture_output=True,
                                check=True).stdout.decode("utf-8", "surrogateescape")
        return [os.path.join(top, p) for p in listed.split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        found = []
        for here, dirs, files in os.walk(start):
            dirs[:] = [d for d in dirs if not d.startswith(".")]
            found += [os.path.join(here, f) for f in files if f.endswith(".arch")]
        return found


class _File:
    """What the hook needs of a file: whether it declares a system, and what it includes (real paths)."""

    def __init__(self, path: str, parse_always: bool) -> None:
        self.path = path
        self.system: Optional[bool] = None      # None: it does not parse (or cannot be read)
        self.includes: list[str] = []
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except (OSError, UnicodeDecodeError):
            return
        if not parse_always and "include" not in text:
            self.system = None                  # not parsed: includes nothing, so it is no one's root
            return
        try:
            doc = parse_text(text.removeprefix("\ufeff"), path)
        except DiagnosticError:
            return
        self.system = doc.system is not None
        here = os.path.dirname(path)
        self.includes = [os.path.realpath(os.path.join(here, item.path)) for item in doc.items
                         if isinstance(item, ir.Include)]


def roots_of(staged: list[str], repository: list[str]) -> tuple[list[str], list[str]]:
    """(the root files to check, the staged files no system includes), as given or as found."""
    staged_real = {os.path.realpath(p): p for p in staged}
    files: dict[str, _File] = {}
    for p in staged:
        files[os.path.realpath(p)] = _File(p, parse_always=True)
    for p in repository:
        real = os.path.realpath(p)
        if real not in files:
            files[real] = _File(os.path.relpath(p) if not os.path.relpath(p).startswith("..") else p,
                                parse_always=False)
    included_by: dict[str, set[str]] = {}
    for real, f in files.items():
        for target in f.includes:
            included_by.setdefault(target, set()).add(real)
    roots: dict[str, str] = {}
    alone: list[str] = []
    for real, given in staged_real.items():
        own = files[real].system          # True, False, or None when it does not parse
        if own:
            roots.setdefault(real, given)
        found = False
        seen, todo = {real}, [real]
        while todo:
            for parent in included_by.get(todo.pop(), ()):
                if parent not in seen:
                    seen.add(parent)
                    todo.append(parent)
                    if files[parent].system:
                        roots.setdefault(parent, files[parent].path)
                        found = True
        if own is None and not found:
            roots.setdefault(real, given)   # checking it says why it does not parse
        elif own is False and not found:
            alone.append(given)
    return sorted(roots.values()), alone


def _run(args: list[str]) -> int:
    try:
        reconf.main(args=args, prog_name="reconf", standalone_mode=False)
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (EXIT_OK if e.code is None else EXIT_BAD_INPUT)
    except click.exceptions.Exit as e:
        return e.exit_code
    except click.ClickException as e:
        e.show()
        return EXIT_BAD_INPUT
    return EXIT_OK


@click.group()
def hooks() -> None:
    """pre-commit hooks for .arch files."""


@hooks.command("check")
@click.argument("files", nargs=-1)
@engine_option
@solver_option
def check_hook(files: tuple[str, ...], engine: Engine, solver: str) -> None:
    """Check every system the staged FILES belong to."""
    staged = [f for f in files if f.endswith(".arch")]
    roots, alone = roots_of(staged, repository_files(os.getcwd()))
    for f in alone:
        console().print(f"[yellow]note[/]: {f} declares no system and no system of the repository includes it: "
                        "not checked")
    worst = EXIT_OK
    for root in roots:
        if len(roots) > 1:
            console().print(f"[bold]reconf check {root}[/]")
        code = _run(["check", "--engine", engine.value, "--solver", solver, root])
        worst = max(worst, code) if code in (EXIT_OK, EXIT_UNSAFE, EXIT_BAD_INPUT) else EXIT_BAD_INPUT
    sys.exit(worst)


@hooks.command("fmt")
@click.argument("files", nargs=-1)
def fmt_hook(files: tuple[str, ...]) -> None:
    """Rewrite FILES in the canonical layout; fail when one changed."""
    if not files:
        sys.exit(EXIT_OK)

    def contents() -> dict[str, Optional[bytes]]:
        out: dict[str, Optional[bytes]] = {}
        for f in files:
            try:
                with open(f, "rb") as fh:
                    out[f] = fh.read()
            except OSError:
                out[f] = None
        return out

    before = contents()
    code = _run(["fmt", *files])
    after = contents()
    changed = [f for f in files if before[f] != after[f]]
    if code != EXIT_OK:
        sys.exit(code)
    if changed:
        console().print(f"reconf-fmt: reformatted {plural(len(changed), 'file')}; "
                        "stage the changes and commit again")
        sys.exit(EXIT_UNSAFE)
    sys.exit(EXIT_OK)


if __name__ == "__main__":
    hooks(prog_name="python -m checker.cli.hooks")
