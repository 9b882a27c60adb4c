"""`reconf gate` as a CI pipeline runs it: a fix of an unsafe base, --detailed-exitcode."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from checker.cli import EXIT_CHANGES, main
from tests.examples_table import BY_NAME
from tests.test_formats import validate_sarif

CHATTER, SLOW, REDUNDANT = BY_NAME["chatter"].file, BY_NAME["chatter_slow"].file, BY_NAME["redundant"].file


def gate(*args: str, fmt: str = "json") -> tuple[int, str, str]:
    result = CliRunner().invoke(main, ["gate", *args, "--output-format", fmt, "--engine", "python"])
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".git").mkdir()  # stops the policy search here
    return tmp_path


# ---------------------------------------------------------------- an unsafe base

def test_a_fix_of_an_unsafe_base_fails_by_default_and_says_how_to_let_it_through(here) -> None:
    code, out, _ = gate("--base", SLOW, "--head", CHATTER)
    assert code == 1
    doc = json.loads(out)
    (d,) = doc["diagnostics"]
    assert d["code"] == "RC509" and d["severity"] == "error"
    assert "the base chatter is not safe" in d["message"] and "chatter is safe" in d["message"]
    assert any("--allow-unsafe-base" in n and "allow-unsafe-base = true" in n and "other means" in n
               for n in d["notes"])
    assert d["span"]["file"].endswith("chatter_slow.arch")
    assert doc["safe"] is True and doc["base_safe"] is False


def test_the_flag_lets_a_fix_through_with_a_warning(here) -> None:
    code, out, _ = gate("--base", SLOW, "--head", CHATTER, "--allow-unsafe-base", fmt="sarif")
    assert code == 0
    (r,) = validate_sarif(out)["runs"][0]["results"]
    assert r["ruleId"] == "RC510" and r["level"] == "warning"
    assert "deploy it by other means" in r["message"]["text"]
    code, _, _ = gate("--base", SLOW, "--head", CHATTER, "--allow-unsafe-base", "--detailed-exitcode")
    assert code == EXIT_CHANGES      # something is to be deployed, by other means


def test_the_policy_key_lets_a_fix_through(here) -> None:
    (here / "reconf.toml").write_text("allow-unsafe-base = true\n", encoding="utf-8")
    code, out, err = gate("--base", SLOW, "--head", CHATTER, fmt="text")
    assert code == 0, out
    assert "warning[RC510]" in err and "allow-unsafe-base = true in the policy in reconf.toml" in err


def test_an_unsafe_head_still_fails_when_unsafe_bases_are_allowed(here) -> None:
    code, out, _ = gate("--base", SLOW, "--head", SLOW, "--allow-unsafe-base")
    assert code == 1
    codes = {d["code"] for d in json.loads(out)["diagnostics"]}
    assert codes == {"RC201", "RC507"}


# ---------------------------------------------------------------- --detailed-exitcode

def test_detailed_exitcode(here) -> None:
    assert gate("--base", CHATTER, "--head", CHATTER, "--detailed-exitcode")[0] == 0        # nothing to do
    assert gate("--base", CHATTER, "--head", REDUNDANT, "--detailed-exitcode")[0] == 3      # safe, with steps
    assert gate("--base", CHATTER, "--head", SLOW, "--detailed-exitcode")[0] == 1           # unsafe
    assert gate("--base", CHATTER, "--head", "none.arch", "--detailed-exitcode")[0] == 2    # bad input
    # without the flag, as before
    assert gate("--base", CHATTER, "--head", REDUNDANT)[0] == 0
    (here / "reconf.toml").write_text("max-disruption = 0\n", encoding="utf-8")
    assert gate("--base", CHATTER, "--head", REDUNDANT, "--detailed-exitcode")[0] == 1      # over the policy
