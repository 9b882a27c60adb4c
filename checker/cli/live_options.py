"""Options and the snapshot reading `reconf discover` and `reconf drift` share
(docs/runtime.md#discover): the namespace, how long discovery may take, and a saved snapshot
in place of the live system."""
from __future__ import annotations

from typing import Any, Callable, Optional

import click

from checker.cli.common import Failure, console, write_atomically
from checker.reality.node_text import model_names
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.span import Span
from reconf_dsl.words import plural
from reconf_ros.executor.snapshot import RosUnavailable, Snapshot, read_snapshot

F = Callable[..., Any]


def live_options(fn: F) -> F:
    for opt in reversed([
        click.option("--namespace", default="", metavar="NS", help="the system's ROS namespace (default: the root)"),
        click.option("--settle", type=click.FloatRange(min=0), default=10.0, show_default=True, metavar="SECONDS",
                     help="at most this long for discovery to settle: one Fast DDS announcement period (3 s) and "
                          "a margin, 3.5 s in all, and the graph quiet for 1 s"),
        click.option("--timeout", type=click.FloatRange(min=0.1), default=5.0, show_default=True, metavar="SECONDS",
                     help="for each node's answer (lifecycle state, parameters), read-only calls retried"),
        click.option("--snapshot", "snapshot_in", type=click.Path(dir_okay=False), metavar="FILE",
                     help="read this snapshot (saved with --save-snapshot) instead of the live system"),
        click.option("--save-snapshot", "snapshot_out", type=click.Path(dir_okay=False), metavar="FILE",
                     help="also write what was read of the live system here (JSON)"),
    ]):
        fn = opt(fn)
    return fn


def _refuse_live_options() -> None:
    """--namespace, --settle and --timeout with --snapshot are a usage error, not silently ignored."""
    ctx = click.get_current_context(silent=True)
    given = [f"--{name}" for name in ("namespace", "settle", "timeout") if ctx is not None and
             ctx.get_parameter_source(name) not in (None, click.core.ParameterSource.DEFAULT)]
    if given:
        raise click.UsageError(f"{', '.join(given)}: read the live system, not a --snapshot")


def snapshot(namespace: str, settle: float, timeout: float, snapshot_in: Optional[str],
             snapshot_out: Optional[str], expect: frozenset[str] = frozenset()) -> Snapshot:
    """The live system (or a saved snapshot; `expect`: the components whose nodes discovery waits
    for); RC602 when neither can be read, or when discovery did not settle and saw none of them."""
    def fail(why: str, where: str, *notes: str) -> Failure:
        return Failure([Diagnostic("RC602", Severity.ERROR, why, Span.unknown(where), notes=notes)])
    setup = ("pip install 'reconf[ros]' for the live system; the nodes must share ROS_DOMAIN_ID and the DDS "
             "set-up (eval \"$(reconf-node --dds-env)\")")
    if snapshot_in:
        _refuse_live_options()
        try:
            with open(snapshot_in, encoding="utf-8") as fh:
                snap = Snapshot.from_json(fh.read())
        except OSError as e:
            raise fail(f"cannot read the snapshot {snapshot_in}: {e.strerror or e}", snapshot_in) from None
        except ValueError as e:
            raise fail(f"{snapshot_in} is not a snapshot: {e}", snapshot_in,
                       "a snapshot is the JSON file `reconf discover` or `reconf drift` writes with "
                       "--save-snapshot") from None
    else:
        say = console()
        try:
            snap = read_snapshot(model_names, namespace, settle, timeout, progress=lambda m: say.print(m), expect=expect)
        except RosUnavailable as e:
            raise fail(f"cannot read the live system: {e}", "<ros>", setup) from None
        note = "" if snap.settled else f", discovery not settled within --settle {settle:g} s"
        say.print(f"read {plural(len(snap.nodes), 'node')} and {plural(len(snap.topics), 'topic')} in "
                  f"{snap.seconds:.1f} s ({snap.settle_seconds:.1f} s waiting for discovery, "
                  f"{snap.seconds - snap.settle_seconds:.1f} s reading){note}")
    seen = {n.name for n in snap.nodes.values()} | {n.component for n in snap.nodes.values() if n.component}
    if not snap.settled and (not snap.nodes or (expect and not expect & seen)):
        none = "no node" if not snap.nodes else f"none of the model's {plural(len(expect), 'node')}"
        within = "" if snapshot_in else f" within --settle {settle:g} s"
        raise fail(f"nothing of the system could be read: discovery did not settle{within} and saw {none}",
                   snapshot_in or "<ros>", *(() if snapshot_in else
                                             (setup, "a longer --settle if the system is large or just started")))
    if snapshot_out:
        write_atomically(snapshot_out, snap.to_json() + "\n")
    return snap
