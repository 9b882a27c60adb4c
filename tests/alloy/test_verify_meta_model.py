"""`reconf verify-meta-model`: outcomes against expectations, counterexamples as two
configurations, exit codes."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner

from checker.alloy import AlloyBridge, metamodel_modules
from checker.alloy.metamodel import MAIN
from checker.alloy.verify_meta_model import PAPER_SIGS, CommandRow, VerifyReport, verify_meta_model
from checker.cli.verify_meta_model_cmd import verify_meta_model_cmd
from codegen.alloy import DEFAULT_SCOPE

ROOT = Path(__file__).resolve().parents[2]


def _mutated(tmp_path: Path) -> Path:
    text = metamodel_modules(3)[MAIN]
    lines = [line for line in text.splitlines(keepends=True) if "--@pre remove.isolated" not in line]
    path = tmp_path / "mutated.als"
    path.write_text("".join(lines), encoding="utf-8")
    return path


def test_json_report_at_small_scope() -> None:
    result = CliRunner().invoke(verify_meta_model_cmd, ["--scope", "3", "--output-format", "json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["ok"] and report["scope"] == 3
    rows = {r["command"]: r for r in report["commands"]}
    assert rows["SafeDetach"]["outcome"] == "no counterexample"
    assert rows["SafeDetach"]["scope"].startswith("3")
    assert rows["Detach"]["outcome"] == "instance"
    assert all(r["as_expected"] for r in report["commands"])


def test_counterexample_is_two_configurations(tmp_path: Path) -> None:
    modules = {MAIN: _mutated(tmp_path).read_text(encoding="utf-8")}
    report = verify_meta_model(3, modules=modules)
    assert not report.ok
    # removing an attached component loses validity, and leaves its attachments dangling
    assert [r.command for r in report.rows if r.as_expected is False] == ["SafeRemove", "KeepsOwned"]
    (row,) = [r for r in report.rows if r.command == "SafeRemove"]
    assert row.counterexample is not None
    cex = row.counterexample
    assert cex.action.startswith("remove Component$")
    removed = cex.action.split()[1]
    assert removed in cex.pre.components and removed not in cex.post.components
    assert cex.post.unsatisfied and not cex.pre.unsatisfied


def test_exit_code_1_and_text_counterexample(tmp_path: Path) -> None:
    result = CliRunner().invoke(verify_meta_model_cmd, ["--model", str(_mutated(tmp_path))])
    assert result.exit_code == 1
    assert "SafeRemove counterexample: action remove" in result.stderr
    assert "components present:" in result.stderr and "roles:" in result.stderr


def test_exit_code_2_without_alloy() -> None:
    env = {**os.environ, "RECONF_ALLOY_JAR": "/nonexistent/alloy.jar", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-m", "checker.cli.verify_meta_model_cmd", "--scope", "3"], env=env,
                         capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert out.returncode == 2
    assert "Alloy jar not found" in out.stderr


def test_each_signature_bound_is_stated_as_the_analyzer_sets_it() -> None:
    result = CliRunner().invoke(verify_meta_model_cmd, ["--scope", "3", "--output-format", "json"])
    report = json.loads(result.stdout)
    rows = {r["command"]: r for r in report["commands"]}
    assert rows["SafeDetach"]["bounds"]["Component"] == "<= 3"
    assert rows["SafeDetach"]["bounds"]["Pre"] == "= 1"       # a one sig, exactly
    assert rows["Detach"]["bounds"]["Connector"] == "<= 3"
    # at scope 3 every check is below the paper's `for 5`, and the report says so
    assert len(report["paper_scope"]["below"]) == len(PAPER_SIGS) * sum(r["kind"] == "check" for r in rows.values())
    text = CliRunner().invoke(verify_meta_model_cmd, ["--scope", "3"]).stderr
    assert "atoms per signature in" in text and "NOT covered" in text


def test_the_default_scope_covers_the_papers() -> None:
    modules = metamodel_modules(DEFAULT_SCOPE)
    bridge = AlloyBridge.get()
    bounds = bridge.bounds(modules, MAIN)
    checks = [label for label in bounds if label.startswith("Safe")]
    rows = [CommandRow(label, "check", "", "", "", None, 0.0, "", None,
                       {s: f"<= {n}" for s, (n, _) in bounds[label].items()}) for label in checks]
    assert len(checks) >= 6 and VerifyReport(DEFAULT_SCOPE, "", rows).below_paper() == []
    assert {int(rows[0].bounds[s].split()[-1]) for s in PAPER_SIGS} == {DEFAULT_SCOPE}


def test_one_process_and_two_agree(monkeypatch: object) -> None:
    two = verify_meta_model(3)
    monkeypatch.setenv("RECONF_ALLOY_PROCESSES", "1")  # type: ignore[attr-defined]
    one = verify_meta_model(3)
    assert one.processes == 1 and two.processes == (2 if (os.cpu_count() or 1) >= 2 else 1)
    assert [(r.command, r.outcome, r.bounds) for r in one.rows] == [(r.command, r.outcome, r.bounds) for r in two.rows]


# A fact that empties part of the instance space leaves every check passing; the
# non-vacuity runs (the shapes users write, each expected to have an instance) fail instead.
NOTHING_SATISFIES_NOTHING = ("fact satisfaction {\n  Sem.sat = {p, q: Msg |",
                             "fact satisfaction {\n  Sem.sat = Nothing -> Nothing + {p, q: Msg |")
PLANTED = [
    # (and attaching an input that assumes nothing to a connector that guarantees nothing
    # would then be allowed whatever the types)
    (NOTHING_SATISFIES_NOTHING, {"SilentDegraded", "TalkerListener", "RatelessConnectorBroken",
                                 "SatEncodingsAgree", "SatisfactionRule", "KeepsTyped"}),
    # no `single` topic and no service: KeepsSingle and KeepsOneServer pass vacuously
    (("-- Configurations ---", "fact { no Kinds.singles + Kinds.services }\n-- Configurations ---"),
     {"SingleTopicPublisher", "ServiceServer", "SecondPublisherRefused"}),
    (("-- Configurations ---", "fact { all f: Functionality | no f.nasms }\n-- Configurations ---"),
     {"TalkerListener", "PortOnTwoConnectors", "SingleTopicPublisher", "RecoverBreaksAReader"}),
]


def test_planted_facts_fail_the_non_vacuity_runs() -> None:
    text = metamodel_modules(3)[MAIN]
    for (right, planted), failing in PLANTED:
        assert text.count(right) == 1, right
        report = verify_meta_model(3, modules={MAIN: text.replace(right, planted)})
        assert not report.ok
        assert {r.command for r in report.rows if r.as_expected is False} == failing
        # the six Safe checks pass all the same: they are what a vacuous fact hides from
        assert all(r.as_expected for r in report.rows if r.command.startswith(("Safe", "KeepsSingle", "KeepsOne")))
