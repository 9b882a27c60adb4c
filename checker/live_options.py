"""Options and the snapshot reading `reconf discover` and `reconf drift` share
(docs/runtime.md#discover): the namespace, how long discovery may take, and a saved snapshot
in place of the live system."""
from __future__ import annotations

from typing import Any, Callable, Optional

import click

from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.span import Span
from reconf_ros.graph import RosUnavailable, Snapshot, read_snapshot

from .command import Failure, console, write_atomically
from .report import plural

F = Callable[..., Any]


def live_options(fn: F) -> F:
    for opt in reversed([
        click.option("--namespace", default="", metavar="NS", help="the system's ROS namespace (default: the root)"),
        click.option("--settle", type=click.FloatRange(min=0), default=10.0, show_default=True, metavar="SECONDS",
                     help="at most this long for discovery to settle: one Fast DDS announcement period (3.5 s) "
                          "and the graph quiet for 1 s"),
        click.option("--timeout", type=click.FloatRange(min=0.1), default=5.0, show_default=True, metavar="SECONDS",
                     help="for each node's answer (lifecycle state, parameters), read-only calls retried"),
        click.option("--snapshot", "snapshot_in", type=click.Path(dir_okay=False), metavar="FILE",
                     help="read this snapshot (saved with --save-snapshot) instead of the live system"),
        click.option("--save-snapshot", "snapshot_out", type=click.Path(dir_okay=False), metavar="FILE",
                     help="also write what was read of the live system here (JSON)"),
    ]):
        fn = opt(fn)
    return fn


def snapshot(namespace: str, settle: float, timeout: float, snapshot_in: Optional[str],
             snapshot_out: Optional[str], expect: frozenset[str] = frozenset()) -> Snapshot:
    """The live system (or a saved snapshot); RC602 when neither can be read."""
    def unavailable(why: str, where: str) -> Failure:
        return Failure([Diagnostic("RC602", Severity.ERROR, why, Span.unknown(where),
                                   notes=("pip install 'reconf[ros]' for the live system; the nodes must share "
                                          "ROS_DOMAIN_ID and the DDS set-up (eval \"$(reconf-node --dds-env)\")",))])
    if snapshot_in:
        try:
            with open(snapshot_in, encoding="utf-8") as fh:
                snap = Snapshot.from_json(fh.read())
        except (OSError, ValueError, TypeError, KeyError, AttributeError) as e:
            raise unavailable(f"cannot read the snapshot {snapshot_in}: {e}", snapshot_in) from None
    else:
        say = console()
        try:
            snap = read_snapshot(namespace, settle, timeout, progress=lambda m: say.print(m), expect=expect)
        except RosUnavailable as e:
            raise unavailable(f"cannot read the live system: {e}", "<ros>") from None
        note = "" if snap.settled else f", discovery not settled within --settle {settle:g} s"
        say.print(f"read {plural(len(snap.nodes), 'node')} and {plural(len(snap.topics), 'topic')} in "
                  f"{snap.seconds:.1f} s{note}")
    if snapshot_out:
        write_atomically(snapshot_out, snap.to_json() + "\n")
    return snap
