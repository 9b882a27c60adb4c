"""`reconf recover`: bring the running system back to a valid configuration, whatever happened to
a plan or the nodes under it (docs/executor.md#failure-and-recovery).

    reconf recover REPORT [--back]      from what a failed or interrupted run observed (its report),
                                        on to the plan's target, or back to its start
    reconf recover --live -f FILES      from the running system read now, to FILES' deployed
                                        configuration (a plan script killed, a node crashed, an
                                        operator's change)

Either way the plan first degrades what fails in the observed configuration, then plans as
usual, and is verified as any plan; it is carried out at once by the plan scripts' executor
(its options are the script's own, as for `reconf up`), or written with `-o`."""
from __future__ import annotations

import os
from typing import Any, Optional

import click

from checker.cli.bringup_cmd import applier, script_argv, with_script_options
from checker.cli.common import Failure, console, guarded, read_run_report
from checker.cli.live_options import snapshot
from checker.cli.plan_cmd import default_files, run
from checker.cli.plan_options import with_plan_options
from checker.ftm.resume import watchers_last
from checker.planning.bringup import up_state
from checker.planning.chain import Fallback
from checker.planning.recovery import plan_recovery
from checker.reality.observed import NotReadable, observed
from checker.semantic_model.config import Configuration
from codegen.ros2 import state_at, system_from_model_data
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.loader import Sources, load
from reconf_dsl.span import Span


def _config(doc: dict[str, Any]) -> Configuration:
    return Configuration(frozenset(doc["components"]), frozenset(tuple(d) for d in doc["degraded"]),
                         frozenset(tuple(r) for r in doc["roles"]))


@click.command("recover")
@click.argument("report", required=False, type=click.Path(dir_okay=False, exists=True))
@click.option("--back", is_flag=True, help="with REPORT: plan back to the plan's first state instead of on to its target")
@click.option("--live", is_flag=True,
              help="plan from the running system, read now, to the deployed configuration of -f FILES (no report)")
@click.option("-f", "--file", "files", multiple=True, type=click.Path(dir_okay=False),
              help="with --live: the architecture (repeatable; default: the one *.arch here, or $RECONF_ARCH)")
@click.option("--settle", type=click.FloatRange(min=0), default=10.0, show_default=True, metavar="SECONDS",
              help="with --live: at most this long for discovery to settle (one announcement period, then a quiet graph)")
@click.option("--snapshot", "snapshot_in", type=click.Path(dir_okay=False), metavar="FILE",
              help="with --live: plan from this snapshot (--save-snapshot of drift or discover) instead")
@click.option("--save-snapshot", "snapshot_out", type=click.Path(dir_okay=False), metavar="FILE",
              help="with --live: also write what was read of the live system here (JSON)")
@with_plan_options
@with_script_options
@guarded("recover")
def recover_cmd(report: Optional[str], back: bool, live: bool, files: tuple[str, ...], settle: float,
                snapshot_in: Optional[str], snapshot_out: Optional[str], sources: Sources, **opts: Any) -> None:
    """Plan from what a failed or interrupted run observed (REPORT) to the plan's target (or,
    --back, its start); or, with --live, from the running system to the deployed configuration
    of -f FILES. What fails is degraded first; the plan is verified as any plan, then carried
    out (or, with -o, written as a script)."""
    if live == (report is not None):
        raise click.UsageError("give either a run REPORT or --live (with -f FILES), not both")
    if report is not None and (files or snapshot_in or snapshot_out):
        raise click.UsageError("-f, --snapshot and --save-snapshot go with --live; a REPORT carries its model")
    if live and back:
        raise click.UsageError("--back goes with a REPORT: --live plans to the deployed configuration of -f FILES")
    namespace, timeout = opts["run_namespace"], opts["run_timeout"]
    apply = applier(script_argv(opts), "reconf recover")
    if report is not None:
        _from_report(report, back, sources, apply, opts)
    else:
        snap_opts = (namespace, settle, timeout, snapshot_in, snapshot_out)
        _from_live(list(files) or default_files(), snap_opts, sources, apply, opts)


def _from_report(report: str, back: bool, sources: Sources, apply: Any, opts: dict[str, Any]) -> None:
    doc = read_run_report(report, "observed", "a plan script's run report with an observed configuration "
                          "(written by --report, or on any failure)")
    if doc.get("unread"):
        raise Failure([Diagnostic("RC632", Severity.ERROR, f"{report}: the run could not read "
                                  f"{', '.join(doc['unread'])} (no answer): its configuration is not known",
                                  Span.unknown(report), notes=("recover from the live system instead: "
                                                               "reconf recover --live -f FILES",))])
    plan_doc = doc["plan_document"]
    system = system_from_model_data(plan_doc["model"])
    seen = _config(doc["observed"])
    target = _config(state_at(plan_doc["plan"], 0 if back else -1))
    renames: Optional[dict[str, str]] = plan_doc["plan"].get("renames") or None
    placed = {c: n for c, n in (doc.get("placed") or {}).items() if c in seen.components}
    label = f"recover {os.path.basename(report)} → {'the start' if back else 'the target'}"

    def make(fb: Fallback) -> Any:
        p = plan_recovery(system, seen, target, opts["strategy"], fb, placed=placed, reorder=watchers_last)
        if renames:
            p.renames.update(renames)
        return p
    run(label, system, make, sources, chain=True, apply=apply, **opts)


Reading = tuple[str, float, float, Optional[str], Optional[str]]   # namespace, settle, timeout, snapshots


def _from_live(files: list[str], snap_opts: Reading, sources: Sources, apply: Any, opts: dict[str, Any]) -> None:
    system = load(files, sources)
    target = up_state(system)
    # discovery settles by the executor's rule alone (one announcement period, then a quiet
    # graph): a component whose node is missing, the usual case here, would cost drift's wait
    # for every model node; the plan's own check reads the system again before its first step
    snap = snapshot(*snap_opts)
    try:
        live = observed(system, snap, target)
    except NotReadable as e:
        raise Failure([Diagnostic("RC632", Severity.ERROR, f"cannot plan from the live system: {e}",
                                  Span.unknown("<ros>"), notes=("run it again once the node answers, or give it "
                                                                "a longer --timeout",))]) from None
    out = console()
    for note in live.notes:
        out.print(f"warning[{note.code}]: {note.message}", markup=False)
    for orphan in live.orphans:
        out.print(f"orphan: {orphan['node']} (pid {orphan['pid'] or 'unknown'}): {orphan['why']}; ended before "
                  "the first step", markup=False)
    label = f"recover {system.name} from the live system → its deployed configuration"

    def make(fb: Fallback) -> Any:
        return plan_recovery(live.system, live.config, live.retarget(target), opts["strategy"], fb,
                             placed=live.placed, orphans=live.orphans, renames=live.renames, reorder=watchers_last)
    run(label, live.system, make, sources, chain=True, apply=apply, **opts)
