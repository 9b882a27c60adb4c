"""`reconf discover`: the running ROS 2 system as an `.arch` (docs/runtime.md#discover)."""
from __future__ import annotations

import sys
from typing import Optional

import click

from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.loader import Sources, load_text
from reconf_dsl.span import Span

from . import report
from .command import console, guarded, plural, write_atomically
from .discover import PLACEHOLDER, architecture
from .live_options import live_options, snapshot


def placeholders(text: str, file: str) -> list[Diagnostic]:
    """One RC601 warning per `// placeholder:` comment of `text`, at its line."""
    out = []
    for i, line in enumerate(text.splitlines(), 1):
        col = line.find(PLACEHOLDER)
        if col >= 0:
            out.append(Diagnostic("RC601", Severity.WARNING, line[col + len(PLACEHOLDER):],
                                  Span(file, i, col + 1, i, len(line) + 1)))
    return out


@click.command("discover")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write the .arch here instead of stdout")
@click.option("--system", "system_name", metavar="NAME", help="the system's name (default: the namespace's, "
                                                               "else `discovered`)")
@live_options
@guarded("discover")
def discover_cmd(output: Optional[str], system_name: Optional[str], namespace: str, settle: float, timeout: float,
                 snapshot_in: Optional[str], snapshot_out: Optional[str], sources: Sources) -> None:
    """Read the live ROS 2 graph and write it as an .arch: exact for reconf nodes (their
    reconf.model), with `// placeholder:` guesses, each a warning, for other nodes."""
    snap = snapshot(namespace, settle, timeout, snapshot_in, snapshot_out)
    name = system_name or namespace.strip("/").replace("/", "_") or "discovered"
    text = architecture(snap, name)
    where = output or "<stdout>"
    load_text(text, where, sources)          # what `reconf check` reads: a failure here is reconf's bug
    if output:
        write_atomically(output, text)
    else:
        click.echo(text, nl=False)
    found = placeholders(text, where)
    report.render_text(found, sources, sys.stderr)
    modelled = sum(1 for n in snap.nodes.values() if n.model)
    console().print(f"{'wrote ' + output if output else 'discovered'}: {plural(modelled, 'reconf node')}, "
                    f"{plural(len(found), 'placeholder')}")
