"""Counts in what people read agree in number: `1 step`, `3 steps`; `the 1 state is valid`,
`all 3 states valid`; `1 distinct host is given`. Each line is rendered with one and with many."""
from __future__ import annotations

import io
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from reconf_dsl.loader import load
from reconf_dsl.words import agree, plural
from tests.examples_table import BY_NAME, ROOT

CHATTER = BY_NAME["chatter"].file
IDLE = """system chatter

component idle {
  host robot
}
"""


def test_plural_and_agree() -> None:
    assert [plural(n, "step") for n in (0, 1, 2)] == ["0 steps", "1 step", "2 steps"]
    assert plural(1, "functionality", "functionalities") == "1 functionality"
    assert plural(3, "functionality", "functionalities") == "3 functionalities"
    assert [agree(n, "does", "do") for n in (0, 1, 2)] == ["do", "does", "do"]


def _plan(*args: str) -> str:
    result = CliRunner().invoke(main, ["plan", *args])
    assert result.exit_code == 0, result.output
    return " ".join(result.stderr.split())


@pytest.mark.alloy
def test_plan_lines_with_one_and_with_many(tmp_path: Path) -> None:
    idle = tmp_path / "idle.arch"
    idle.write_text(IDLE, encoding="utf-8")
    one = _plan("add", "idle", "--from", str(idle), "-f", CHATTER)
    assert "reconf will add idle in 1 step (strategy default)" in one
    assert "Plan: 1 action (1 create); 0 functionalities degraded; longest degradation 0 steps." in one
    assert "Alloy: 2 states valid, 1 transition is an instance of its action (" in one
    assert "(on the 1 component the plan can affect; the other 2 read nothing it changes and were judged once)" in one
    none = _plan("migrate", CHATTER, CHATTER)
    assert "in 0 steps" in none and "every precondition holds, the 1 state is valid" in none
    assert "Alloy: 1 state valid, 0 transitions are instances of their actions (" in none
    many = _plan("replace", "talker", "-f", CHATTER)
    assert "in 5 steps" in many and "every precondition holds, all 6 states valid" in many
    assert "Alloy: 6 states valid, 5 transitions are instances of their actions (" in many
    removed = _plan("remove", "listener", "-f", CHATTER)
    assert "the 1 other reads nothing it changes and was judged once" in removed


def test_plan_summary_with_one_and_with_many(tmp_path: Path) -> None:
    from checker.planning import plan_add, plan_replace
    idle = tmp_path / "idle.arch"
    idle.write_text(IDLE, encoding="utf-8")
    system = load([CHATTER])
    assert plan_add(system, "idle", source=load([str(idle)])).summary().startswith("1 step (1 create);")
    assert plan_replace(system, "talker", "talker_v2").summary().startswith("5 steps (")


def test_duplex_on_too_few_hosts(tmp_path: Path) -> None:
    from checker.ftm.diagnose import ftm_diagnostics
    text = open(os.path.join(ROOT, "examples", "ftm", "deterministic_lfr.arch"), encoding="utf-8").read()
    for hosts, words in (("site_a, site_a", "but 1 distinct host is given"), ("", "but no distinct hosts are given")):
        path = tmp_path / "x.arch"
        path.write_text(text.replace("on site_a, site_b", f"on {hosts}" if hosts else ""), encoding="utf-8")
        found = [d.message for d in ftm_diagnostics(load([str(path)])) if d.code == "RC406"]
        assert len(found) == 1 and found[0].endswith(words), found


def _replay(states: int) -> str:
    from checker.planning import plan_migrate, plan_replace
    from checker.reports.plan_document import plan_document
    from reconf_ros.executor.replay import replay
    system = load([CHATTER])
    plan = plan_replace(system, "talker", "talker_v2") if states > 1 else plan_migrate(system, system)
    assert len(plan.states) == states
    out = io.StringIO()
    assert replay(plan_document("replace", plan.system, plan, {}, model=True), out)
    return out.getvalue()


def test_dry_run_with_one_state_and_with_many() -> None:
    assert "dry run: the 1 state is safe" in _replay(1)
    assert "dry run: all 6 states are safe" in _replay(6)


def test_executor_plural() -> None:
    from reconf_ros.executor.steps import plural as executor_plural
    assert [executor_plural(n, "subscriber") for n in (1, 2)] == ["1 subscriber", "2 subscribers"]


@pytest.mark.parametrize("rows, said", [(1, "1 command in"), (3, "3 commands in")])
def test_verify_meta_model_summary(rows: int, said: str) -> None:
    from rich.console import Console

    from checker.alloy.verify_meta_model import CommandRow, VerifyReport
    from checker.cli.verify_meta_model_cmd import _render_text
    report = VerifyReport(3, "sat4j", [CommandRow(f"c{i}", "run", "3", "instance", "instance", True, 0.1, "sat4j",
                                                  bounds={"A": "<= 3"}) for i in range(rows)], wall=1.0)
    out = io.StringIO()
    _render_text(report, Console(file=out, width=200))
    text = out.getvalue()
    assert said in text
    assert f"atoms per signature in {plural(rows, 'run')}: A <= 3" in text
