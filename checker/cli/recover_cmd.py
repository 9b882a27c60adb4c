"""`reconf recover REPORT`: plan from the configuration a failed run observed (its report) on to
the plan's target, or back to its start (docs/executor.md#failure-and-recovery)."""
from __future__ import annotations

import json
import os
from typing import Any, Optional

import click

from checker.cli.common import guarded
from checker.cli.plan_cmd import run
from checker.cli.plan_options import with_plan_options
from checker.model.config import Configuration
from checker.planning.recovery import plan_recovery
from codegen.ros2 import state_at, system_from_model_data
from reconf_dsl.loader import Sources


def _config(doc: dict[str, Any]) -> Configuration:
    return Configuration(frozenset(doc["components"]), frozenset(tuple(d) for d in doc["degraded"]),
                         frozenset(tuple(r) for r in doc["roles"]))


def read_report(path: str) -> dict[str, Any]:
    try:
        with open(path, encoding="utf-8") as fh:
            report = json.load(fh)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise click.UsageError(f"{path}: cannot read it as a run report ({e})") from None
    if not isinstance(report, dict) or report.get("kind") != "run-report" or not report.get("observed"):
        raise click.UsageError(f"{path}: not a plan script's run report with an observed configuration "
                               "(written by --report, or on any failure)")
    return report


@click.command("recover")
@click.argument("report", type=click.Path(dir_okay=False, exists=True))
@click.option("--back", is_flag=True, help="plan back to the plan's first state instead of on to its target")
@with_plan_options
@guarded("recover")
def recover_cmd(report: str, back: bool, sources: Sources, **opts: Any) -> None:
    """Plan from what a failed run observed to the plan's target (or, --back, its start)."""
    doc = read_report(report)
    plan_doc = doc["plan_document"]
    system = system_from_model_data(plan_doc["model"])
    observed = _config(doc["observed"])
    target = _config(state_at(plan_doc["plan"], 0 if back else -1))
    renames: Optional[dict[str, str]] = plan_doc["plan"].get("renames") or None
    label = f"recover {os.path.basename(report)} → {'the start' if back else 'the target'}"

    def make() -> Any:
        p = plan_recovery(system, observed, target, opts["strategy"])
        if renames:
            p.renames.update(renames)
        return p
    run(label, system, make, sources, **opts)
