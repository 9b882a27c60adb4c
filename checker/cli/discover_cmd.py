"""`reconf discover`: the running ROS 2 system as an `.arch` (docs/runtime.md#discover)."""
from __future__ import annotations

import re
import sys
from typing import Optional

import click

from checker.cli.common import console, guarded, plural, write_atomically
from checker.cli.live_options import live_options, snapshot
from checker.reality.discover import architecture, placeholders
from checker.reports import report
from reconf_dsl.loader import Sources, load_text

SYSTEM_NAME = re.compile(r"[^\W\d]\w*")


def system_name_option(ctx: click.Context, param: click.Parameter, value: Optional[str]) -> Optional[str]:
    if value is not None and not SYSTEM_NAME.fullmatch(value):
        raise click.BadParameter(f"{value!r} is not a system name (a letter or _, then letters, digits or _)")
    return value


@click.command("discover")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write the .arch here instead of stdout")
@click.option("--system", "system_name", metavar="NAME", callback=system_name_option, help="the system's name (default: the namespace's, "
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
