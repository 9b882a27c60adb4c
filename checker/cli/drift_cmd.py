"""`reconf drift FILES`: the model's deployed configuration against the running system
(docs/runtime.md#drift). Exit 0 none, 1 drift, 2 not answered."""
from __future__ import annotations

import sys
from typing import Optional

import click

from checker.cli.common import EXIT_OK, EXIT_UNSAFE, console, emit_report, format_option, guarded, plural
from checker.cli.inputs import exclude_option, expand, nothing_left, paths_argument
from checker.cli.live_options import live_options, snapshot
from checker.reality.drift import KINDS, deployed, drift
from checker.reports import formats, report
from checker.reports.report import ReportFormat
from reconf_dsl.loader import Sources, load


@click.command("drift")
@paths_argument
@exclude_option
@format_option
@live_options
@guarded("drift")
def drift_cmd(files: tuple[str, ...], exclude: tuple[str, ...], output_format: ReportFormat, namespace: str,
              settle: float, timeout: float, snapshot_in: Optional[str], snapshot_out: Optional[str],
              sources: Sources) -> None:
    """Compare PATHs' deployed configuration with the running system: components missing or
    extra, attachments, message types, modes, publishers on single topics, lifecycle states."""
    system = load(expand(files, exclude) or nothing_left(files), sources)
    # the model's nodes are waited for, as a plan script waits for its plan's (docs/executor.md)
    snap = snapshot(namespace, settle, timeout, snapshot_in, snapshot_out,
                    frozenset(c.name for c in system.components))
    diags = drift(system, snap)
    _, notes = deployed(system)
    for note in notes:
        console().print(f"note: {note}")
    verdict = "drift" if diags else "in sync"
    line = f"{system.name} — {plural(len(system.components), 'component')} against " \
           f"{plural(len(snap.nodes), 'node')}: " + (plural(len(diags), "difference") if diags else "no difference")
    cases = [formats.CheckCase("reconf.drift", kind, "\n".join(d.message for d in diags if d.code == code) or None)
             for code, kind in KINDS.items()]
    human = f"[bold red]✗ drift[/]: {line}" if diags else f"[bold green]✓ in sync[/]: {line}"
    emit_report(formats.Report("drift", verdict, diags, cases, f"{verdict}: {line}"), output_format, sources,
                lambda: report.document("drift", verdict, diags, system=system.name, files=list(system.files),
                                        nodes=sorted(snap.nodes), settled=snap.settled, deployed_degraded=notes,
                                        seconds={"settle": round(snap.settle_seconds, 3),
                                                 "read": round(snap.seconds - snap.settle_seconds, 3)}), human)
    sys.exit(EXIT_UNSAFE if diags else EXIT_OK)
