"""One entry point plans a change (checker.ftm.plan_change): `plan migrate`, `gate` and `graph-plan`
plan a change between architectures with FTMs on their expansions, and so the same plan."""
from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from checker.cli.main import main
from checker.ftm.expand import expand
from checker.ftm.plan_change import planned_on
from checker.reports.plan_document import fingerprint
from reconf_dsl.loader import load

FTM = Path(__file__).resolve().parents[2] / "examples" / "ftm"
BASE, HEAD = str(FTM / "client_server_pbr.arch"), str(FTM / "client_server_pbr_tr.arch")


def test_a_change_with_ftms_is_planned_between_the_expansions() -> None:
    old, new = load([BASE]), load([HEAD])
    deployed, target = planned_on(old, new)
    assert deployed == expand(old)[0] and target == expand(new)[0]
    assert {"server__proxy", "server__r0_dup_protocol"} <= {c.name for c in deployed.components}
    assert planned_on(deployed, deployed) == (deployed, deployed)      # no FTM left: planned as written


def test_plan_migrate_gate_and_graph_plan_make_the_same_plan() -> None:
    """The plan on the expansions, from each command (the planning itself is the same call,
    `plan_change`, so its 64 steps are planned once per command)."""
    planned = CliRunner().invoke(main, ["plan", "migrate", BASE, HEAD, "--no-alloy", "--output-format", "json"])
    assert planned.exit_code == 0, planned.output
    plan_doc = json.loads(planned.stdout)
    gated = CliRunner().invoke(main, ["gate", "--base", BASE, "--head", HEAD, "--engine", "python",
                                      "--output-format", "json"])
    assert gated.exit_code == 0, gated.output
    gate_doc = json.loads(gated.stdout)["plan"]
    assert gate_doc["plan"]["steps"] == plan_doc["plan"]["steps"] and len(plan_doc["plan"]["steps"]) == 64
    assert gate_doc["fingerprint"] == plan_doc["fingerprint"] == fingerprint(expand(load([BASE]))[0])
    drawn = CliRunner().invoke(main, ["graph-plan", BASE, HEAD, "--format", "mermaid"])
    assert drawn.exit_code == 0, drawn.output
    assert "server__r0_dup_protocol" in drawn.stdout and "server__proxy" in drawn.stdout
