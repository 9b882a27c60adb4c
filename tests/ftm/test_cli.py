"""`reconf ftm select|expand` and `reconf plan transition`, through click (Alloy off where slow)."""
from __future__ import annotations

import json

from click.testing import CliRunner

from checker.cli.ftm_cmd import ftm_group, transition_cmd
from reconf_dsl.loader import load_text
from tests.support.ftm import EXAMPLES, assert_prepared_first_cleaned_up_last


def test_select_lists_valid_ranked_and_rejected_with_alloy(bridge) -> None:  # type: ignore[no-untyped-def]
    r = CliRunner().invoke(ftm_group, ["select", "server", "-f", f"{EXAMPLES}/deterministic_lfr.arch",
                                       "--output-format", "json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["attached"] == "LFR" and doc["evidence"]["agrees"]
    valid = [c["ftm"] for c in doc["valid"]]
    assert "LFR" in valid and "PBR" not in valid
    pbr = next(c for c in doc["rejected"] if c["ftm"] == "PBR")
    assert pbr["reasons"][0]["code"] == "RC404"


def test_select_text_exits_1_when_nothing_is_valid(tmp_path) -> None:  # type: ignore[no-untyped-def]
    text = open(f"{EXAMPLES}/client_server_pbr.arch").read().replace("faults crash", "faults crash, omission")
    path = tmp_path / "x.arch"
    path.write_text(text)
    r = CliRunner().invoke(ftm_group, ["select", "server", "-f", str(path), "--no-alloy"])
    assert r.exit_code == 1
    assert "No valid FTM" in r.output and "omission" in r.output


def test_expand_prints_dsl_that_reparses_and_dot() -> None:
    r = CliRunner().invoke(ftm_group, ["expand", "--format", "dsl", f"{EXAMPLES}/client_server_sec_pbr_tr.arch"])
    assert r.exit_code == 0, r.output
    dsl = r.stdout
    system = load_text(dsl)
    assert system.component("server__r1_tr_proceed") is not None
    r = CliRunner().invoke(ftm_group, ["expand", "--format", "dot", f"{EXAMPLES}/client_server_pbr.arch"])
    assert r.exit_code == 0 and r.stdout.startswith("digraph") and '"c:server__recovery"' in r.stdout


def test_plan_transition_json() -> None:
    r = CliRunner().invoke(transition_cmd, ["server", "LFR", "-f", f"{EXAMPLES}/deterministic_pbr.arch",
                                            "--no-alloy", "--output-format", "json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["verdict"] == "plan" and doc["operation"] == "move server from PBR to LFR"
    steps = doc["plan"]["steps"]
    kinds = [s["action"] for s in steps]
    assert kinds.count("create") == 4
    assert_prepared_first_cleaned_up_last(steps)
    # the creates run one at a time (the service is serving: process starts at once would take its
    # CPU), the suspension's steps in batches
    creates = [i for i, k in enumerate(kinds) if k == "create"]     # batches: 0-based, inclusive
    assert doc["plan"]["batches"] and all(sum(a <= c <= b for c in creates) <= 1 for a, b in doc["plan"]["batches"])
    # and the JSON says for how long the client's side (the follower) is expected to wait: not
    # while the nodes start
    seconds = doc["plan"]["seconds"]
    follower = next(f["seconds"] for f in seconds["functionalities"] if f["component"] == "follower")
    assert 0 < follower < seconds["plan"] - seconds["durations"]["kinds"]["create"]


def test_plan_transition_refuses_an_ill_formed_ftm() -> None:
    r = CliRunner().invoke(transition_cmd, ["server", "TR(PBR)", "-f", f"{EXAMPLES}/client_server_pbr.arch",
                                            "--no-alloy"])
    assert r.exit_code == 2 and "RC401" in r.output


def test_plan_transition_among_services_is_verified_in_alloy_on_its_slice_and_loses_nothing(
        tmp_path, bridge) -> None:  # type: ignore[no-untyped-def]
    from bench.bench_ftm import generate
    path = tmp_path / "services.arch"
    path.write_text(generate(3, "TR"))
    r = CliRunner().invoke(transition_cmd, ["server1", "SEC(TR)", "-f", str(path), "--output-format", "json"])
    assert r.exit_code == 0, r.output
    alloy = json.loads(r.stdout)["evidence"]["alloy"]
    assert alloy["valid"], alloy["reason"]
    assert alloy["lossless"] == ["server1__proxy serves /compute1"]
    # the other services read nothing the plan changes: judged once, not in every state
    assert alloy["slice"]["judged_once"] >= 2 * 3  # server0, client0, server2, client2 and their nodes
    r = CliRunner().invoke(transition_cmd, ["server1", "SEC(TR)", "-f", str(path)])
    assert r.exit_code == 0 and "client side kept" in r.output


def test_transition_to_an_ftm_the_component_rules_out_warns_when_allowed() -> None:
    """TR needs a deterministic application: moving the non-deterministic server of
    client_server_pbr.arch to PBR(TR) is planned with --allow-invalid-ftm, with the rule it
    breaks as a warning."""
    args = ["server", "PBR(TR)", "-f", f"{EXAMPLES}/client_server_pbr.arch", "--no-alloy", "--allow-invalid-ftm"]
    r = CliRunner().invoke(transition_cmd, args)
    assert r.exit_code == 0, r.output
    assert "warning: the target breaks an FTM rule: RC403" in r.output
    doc = json.loads(CliRunner().invoke(transition_cmd, args + ["--output-format", "json"]).stdout)
    assert [n for n in doc["plan"]["notes"] if "RC403" in n] == [
        "warning: the target breaks an FTM rule: RC403 TR needs a deterministic application, and the application "
        "is declared non_deterministic ('server')"]
    fine = CliRunner().invoke(transition_cmd, ["server", "LFR", "-f", f"{EXAMPLES}/deterministic_pbr.arch",
                                               "--no-alloy"])
    assert fine.exit_code == 0 and "FTM rule" not in fine.output, fine.output


def test_plan_transition_to_an_ftm_the_rules_rule_out_is_refused_unless_allowed() -> None:
    """The server is not deterministic: LFR is ruled out (RC403), as `reconf check` would say."""
    argv = ["server", "LFR", "-f", f"{EXAMPLES}/client_server_pbr.arch", "--no-alloy"]
    r = CliRunner().invoke(transition_cmd, argv)
    assert r.exit_code == 1 and "RC403" in r.stderr and "--allow-invalid-ftm" in r.stderr, r.output
    r = CliRunner().invoke(transition_cmd, argv + ["--allow-invalid-ftm", "--output-format", "json"])
    assert r.exit_code == 0, r.output
    assert any("RC403" in n for n in json.loads(r.stdout)["plan"]["notes"])


def test_the_gate_refuses_an_ftm_the_rules_rule_out_unless_allowed(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from checker.cli.main import main
    head = tmp_path / "lfr.arch"
    head.write_text(open(f"{EXAMPLES}/client_server_pbr.arch", encoding="utf-8").read()
                    .replace("ftm PBR on master, slave", "ftm LFR on master, slave"), encoding="utf-8")
    argv = ["gate", "--base", f"{EXAMPLES}/client_server_pbr.arch", "--head", str(head), "--engine", "python"]
    r = CliRunner().invoke(main, argv)
    assert r.exit_code == 1 and "RC403" in r.stderr, r.output
    r = CliRunner().invoke(main, argv + ["--allow-invalid-ftm"])
    assert r.exit_code == 0 and "RC403" in r.stderr, r.output
