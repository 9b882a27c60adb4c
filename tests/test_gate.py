"""`reconf gate` on the examples: safe changes pass, unsafe ones fail at the offending line,
changes with no plan inside the policy fail naming the policy, and git:REF:PATH works."""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import jsonschema
import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.ftm.library import LIBRARY
from checker.gate.policy import coverage, load_policy
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.ir import FtmExpr
from tests.examples_table import BY_NAME, ROOT, path
from tests.support.gatekit import gate, git
from tests.support.sarif import sarif_schema

CHATTER, SLOW, REDUNDANT = BY_NAME["chatter"].file, BY_NAME["chatter_slow"].file, BY_NAME["redundant"].file


@pytest.mark.alloy
def test_safe_change_passes(here) -> None:
    code, out, err = gate("--base", CHATTER, "--head", REDUNDANT, engine="both")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["verdict"] == "pass" and doc["safe"] is True and doc["diagnostics"] == []
    assert doc["plan"]["evidence"]["alloy"]["valid"] is True
    assert doc["plan"]["plan"]["steps"]


def test_no_change_passes_in_text(here) -> None:
    code, _, err = gate("--base", CHATTER, "--head", CHATTER, fmt="text")
    assert code == 0
    assert "✓ gate passed" in err


def test_unsafe_change_fails_with_sarif_at_the_offending_line(here) -> None:
    code, out, _ = gate("--base", CHATTER, "--head", SLOW, fmt="sarif")
    assert code == 1
    doc = json.loads(out)
    jsonschema.validate(doc, sarif_schema())
    results = doc["runs"][0]["results"]
    rc201 = [r for r in results if r["ruleId"] == "RC201"]
    assert len(rc201) == 1
    loc = rc201[0]["locations"][0]["physicalLocation"]
    assert loc["artifactLocation"]["uri"].endswith("examples/chatter_slow.arch")
    assert loc["region"]["startLine"] == 21
    assert [r["ruleId"] for r in results] == ["RC201", "RC507"]
    assert results[1]["message"]["text"] == ("chatter is not safe: no migration to it is planned\n"
                                             "note: 1 assumption does not hold; see above")


def test_plan_over_max_disruption_fails_naming_the_policy(here) -> None:
    (here / "reconf.toml").write_text("# gate policy\nmax-disruption = 0\n", encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 1
    doc = json.loads(out)
    (d,) = doc["diagnostics"]
    assert d["code"] == "RC502"
    assert "max-disruption = 0" in d["message"] and "reconf.toml" in d["message"]
    assert d["related"][0]["span"] == {"file": "reconf.toml", "line": 2, "column": 1, "end_line": 2,
                                       "end_column": 19}
    assert doc["policy"]["max-disruption"] == 0


def test_plan_over_max_degraded_seconds_fails_naming_the_policy(here) -> None:
    """The plan from chatter to redundant keeps the listener degraded for its detach (0.01 s
    expected by the measured defaults): within 0.5 s, over 0.005 s."""
    (here / "reconf.toml").write_text("max-degraded-seconds = 0.5\n", encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 0, out
    doc = json.loads(out)
    assert doc["policy"]["max-degraded-seconds"] == 0.5
    (here / "reconf.toml").write_text("max-degraded-seconds = 0.005\n", encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 1
    (d,) = json.loads(out)["diagnostics"]
    assert d["code"] == "RC512" and "over max-degraded-seconds = 0.005" in d["message"]
    assert any(n.startswith("longest: listener.listen") for n in d["notes"])


def test_never_degrade_from_pyproject(here) -> None:
    (here / "pyproject.toml").write_text('[project]\nname = "x"\n\n[tool.reconf]\nnever-degrade = ["listen"]\n',
                                         encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT, fmt="sarif")
    assert code == 1
    results = json.loads(out)["runs"][0]["results"]
    assert {r["ruleId"] for r in results} == {"RC503"}
    assert "never-degrade in the policy in pyproject.toml [tool.reconf]" in results[0]["message"]["text"]


def test_policy_option_overrides(here, tmp_path_factory) -> None:
    (here / "reconf.toml").write_text("max-disruption = 0\n", encoding="utf-8")
    other = tmp_path_factory.mktemp("policy") / "loose.toml"
    other.write_text("max-disruption = 100\n", encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT, "--policy", str(other))
    assert code == 0, out
    doc = json.loads(out)
    assert doc["verdict"] == "pass" and doc["diagnostics"] == []
    assert doc["policy"]["source"] == str(other) and doc["policy"]["max-disruption"] == 100
    # the policy found in the directory alone would refuse the plan (disruption 8 over 0)
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 1 and [d["code"] for d in json.loads(out)["diagnostics"]] == ["RC502"], out


def test_bad_policy_is_bad_input(here) -> None:
    (here / "reconf.toml").write_text("max-disruption = -1\nspeed = 3\n", encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", CHATTER)
    assert code == 2
    codes = {(d["code"], d["span"]["line"]) for d in json.loads(out)["diagnostics"]}
    assert codes == {("RC505", 1), ("RC505", 2)}


FTM_OLD = """system s
message M = std_msgs/msg/String
component server {
  output out: M
  faults crash, transient
  application deterministic, state_access
  ftm PBR(TR)
  functionality serve (out) {
    normal { out: M @ 10 Hz }
    degraded { out: nothing }
  }
}
component client {
  input in: M @ 10 Hz
  functionality use (in) {
    normal { assume M @ 10 Hz }
    degraded { }
  }
}
topic /t: M @ 10 Hz {
  server.out -> client.in
}
"""


def test_weakened_ftm_fails_at_the_ftm_line(here) -> None:
    (here / "old.arch").write_text(FTM_OLD, encoding="utf-8")
    (here / "new.arch").write_text(FTM_OLD.replace("ftm PBR(TR)", "ftm TR"), encoding="utf-8")
    (here / "same.arch").write_text(FTM_OLD.replace("ftm PBR(TR)", "ftm AD"), encoding="utf-8")
    (here / "reconf.toml").write_text('keep-ftm = ["PBR"]\n', encoding="utf-8")
    code, out, _ = gate("--base", "old.arch", "--head", "new.arch", fmt="sarif")
    assert code == 1
    results = json.loads(out)["runs"][0]["results"]
    # TR alone does not tolerate the crash faults the server declares: `check` refuses the
    # head (RC402), and so does the gate (RC507), besides the FTM the policy keeps (RC504)
    assert sorted(r["ruleId"] for r in results) == ["RC402", "RC504", "RC507"]
    (r,) = [r for r in results if r["ruleId"] == "RC504"]
    assert "crash" in r["message"]["text"]
    assert r["locations"][0]["physicalLocation"]["region"]["startLine"] == 7
    code, out, _ = gate("--base", "old.arch", "--head", "same.arch")
    assert code == 0, out


def test_coverage_table() -> None:
    assert coverage(FtmExpr("SEC", FtmExpr("PBR", FtmExpr("TR")))) == {"intrusion", "crash", "transient"}
    assert coverage(FtmExpr("AD")) == {"crash", "transient", "permanent_value"}
    # the policy reads the FTM library's Table I: one table, no copy to drift
    for name, mechanism in LIBRARY.items():
        assert coverage(FtmExpr(name)) == mechanism.covers
    assert coverage(None) == frozenset()


def test_load_policy_errors(tmp_path) -> None:
    with pytest.raises(DiagnosticError):
        load_policy(str(tmp_path / "none.toml"))


@pytest.mark.skipif(shutil.which("git") is None, reason="git is not installed")
def test_git_references(tmp_path, monkeypatch) -> None:
    repo = tmp_path / "repo"
    shutil.copytree(os.path.join(ROOT, "examples"), repo / "arch")
    git(str(repo), "init", "-q")
    git(str(repo), "add", ".")
    git(str(repo), "commit", "-q", "-m", "base")
    shutil.copy(SLOW, repo / "arch" / "chatter.arch")
    git(str(repo), "commit", "-q", "-am", "slower")
    monkeypatch.chdir(repo / "arch")
    # the old version from history against the working tree: nothing is checked out
    code, out, _ = gate("--base", "git:HEAD~1:arch/chatter.arch", "--head", "chatter.arch", fmt="sarif")
    assert code == 1
    (r, _) = json.loads(out)["runs"][0]["results"]
    assert r["ruleId"] == "RC201" and r["locations"][0]["physicalLocation"]["region"]["startLine"] == 21
    # both sides from git; includes are read from the same revision; ./ is relative to here
    code, out, _ = gate("--base", "git:HEAD~1:./robot.arch", "--head", "git:HEAD:arch/robot.arch")
    assert code == 0, out
    code, out, _ = gate("--base", "git:HEAD~1:arch/chatter.arch", "--head", "git:HEAD:arch/chatter.arch")
    doc = json.loads(out)
    assert code == 1 and doc["diagnostics"][0]["span"]["file"] == "chatter.arch"
    assert not [p for p in os.listdir(repo / "arch") if p.startswith("reconf-rev-")]
    code, out, _ = gate("--base", "git:nosuchref:arch/chatter.arch", "--head", "chatter.arch")
    assert code == 2 and json.loads(out)["diagnostics"][0]["code"] == "RC506"


def test_gate_refuses_what_check_refuses_for_ftm_rules(tmp_path: Path) -> None:
    """Base A&D, head LFR, both declaring permanent value faults: `check` refuses the head
    (RC402: LFR does not tolerate them), and so does the gate, with keep-ftm or without."""
    lfr = Path(path("examples", "ftm", "deterministic_lfr.arch")).read_text(encoding="utf-8")
    head = lfr.replace("faults crash\n", "faults crash, permanent_value\n")
    assert head != lfr
    (tmp_path / "base.arch").write_text(head.replace("ftm LFR on", "ftm AD on"), encoding="utf-8")
    (tmp_path / "head.arch").write_text(head, encoding="utf-8")
    (tmp_path / "policy.toml").write_text("[tool.reconf]\nkeep-ftm = true\n", encoding="utf-8")
    check = CliRunner().invoke(main, ["check", str(tmp_path / "head.arch"), "--engine", "python",
                                      "--output-format", "json"])
    assert check.exit_code == 1 and "RC402" in check.stdout
    for extra, weakened in (([], []), (["--policy", str(tmp_path / "policy.toml")], ["RC504"])):
        code, out, _ = gate("--base", str(tmp_path / "base.arch"), "--head", str(tmp_path / "head.arch"), *extra)
        doc = json.loads(out)
        assert code == 1, out
        # with keep-ftm, A&D's permanent value coverage lost is named too (the policy reads Table I)
        assert sorted(d["code"] for d in doc["diagnostics"] if d["severity"] == "error") == \
            ["RC402", *weakened, "RC507"]
