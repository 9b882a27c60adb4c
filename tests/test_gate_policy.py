"""The gate's policy is checked before anything is judged: every value has its type (RC505),
every name names something in the head or the base (RC508, with the closest name), each at
its place in the TOML file; bad input exits 2 and the machine outputs stay valid."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.gate.policy import load_policy, locate
from reconf_dsl.diagnostics import DiagnosticError
from tests.examples_table import BY_NAME
from tests.support.gatekit import gate
from tests.support.sarif import validate_sarif

CHATTER, REDUNDANT = BY_NAME["chatter"].file, BY_NAME["redundant"].file


def diagnostics(out: str) -> list[dict]:
    return json.loads(out)["diagnostics"]


def test_misspelt_functionality_is_bad_input_at_its_place_with_a_suggestion(here) -> None:
    (here / "reconf.toml").write_text('max-disruption = 100\nnever-degrade = ["listen", "detectt"]\n',
                                      encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 2
    (d,) = diagnostics(out)
    assert d["code"] == "RC508" and "detectt" in d["message"] and "protect nothing" in d["message"]
    assert d["span"] == {"file": "reconf.toml", "line": 2, "column": 28, "end_line": 2, "end_column": 37}
    # the base has listener.listen; nothing is close to detectt, so no suggestion is made up
    assert not any("did you mean" in n for n in d["notes"])


def test_suggestions_for_a_component_and_a_functionality(here) -> None:
    (here / "reconf.toml").write_text('never-degrade = [\n  "listner.listen",\n  "listener.lisen",\n  "lisen",\n]\n'
                                      'keep-ftm = ["talkr", "PBR"]\n', encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 2
    found = {(d["span"]["line"], d["span"]["column"]): d for d in diagnostics(out)}
    assert set(found) == {(2, 3), (3, 3), (4, 3), (6, 13)}
    assert {d["code"] for d in found.values()} == {"RC508"}
    assert "did you mean 'listener.listen'?" in found[(2, 3)]["notes"]
    assert "did you mean 'listen'?" in found[(3, 3)]["notes"]
    assert "did you mean 'listen'?" in found[(4, 3)]["notes"]
    assert "did you mean 'talker'?" in found[(6, 13)]["notes"]


def test_names_of_the_base_count(here) -> None:
    """talker and listener are in the base only: a migration degrades them, so they may be protected."""
    (here / "reconf.toml").write_text('never-degrade = ["listener.listen", "map"]\nkeep-ftm = ["talker", "SEC"]\n',
                                      encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT)
    assert code == 1, out              # judged: listener.listen is degraded by the plan
    assert {d["code"] for d in diagnostics(out)} == {"RC503"}


def test_a_string_for_a_boolean_is_refused_with_the_fix(here) -> None:
    (here / "reconf.toml").write_text('keep-ftm = "yes"\nallow-unsafe-base = "no"\n', encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", CHATTER)
    assert code == 2
    ds = diagnostics(out)
    assert [d["code"] for d in ds] == ["RC505", "RC505"]
    assert 'not the string "yes"' in ds[0]["message"] and ds[0]["notes"] == ["write keep-ftm = true (no quotes)"]
    assert ds[0]["span"]["line"] == 1 and ds[0]["span"]["column"] == 12
    assert ds[1]["notes"] == ["write allow-unsafe-base = false (no quotes)"]


@pytest.mark.parametrize("text, message", [
    ('max-disruption = "4"\n', 'max-disruption must be a whole number ≥ 0, not the string "4"'),
    ("max-disruption = 2.5\n", "not the number 2.5"),
    ('max-degraded-seconds = "1"\n', 'max-degraded-seconds must be a number of seconds ≥ 0, not the string "1"'),
    ("max-degraded-seconds = -0.5\n", "not the number -0.5"),
    ('never-degrade = "listen"\n', 'never-degrade must be a list of'),
    ("never-degrade = [3]\n", "each entry of never-degrade must be a name in quotes, not the number 3"),
    ('never-degrade = [""]\n', "an empty name in never-degrade"),
    ('never-degrade = ["a.b.c"]\n', "neither COMPONENT.FUNCTIONALITY nor FUNCTIONALITY"),
    ("keep-ftm = 1\n", "keep-ftm must be true, false, or a list of component and FTM names, not the number 1"),
    ('strategy = "defualt"\n', "did you mean 'default'?"),
    ("strategy = 3\n", "strategy must be one of default, paper, exhaustive (in quotes), not the number 3"),
    ("max-disruptoin = 3\n", "unknown policy key 'max-disruptoin'; did you mean 'max-disruption'?"),
])
def test_each_value_is_type_checked(here, text: str, message: str) -> None:
    (here / "reconf.toml").write_text("# policy\n" + text, encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", CHATTER)
    assert code == 2
    (d,) = diagnostics(out)
    assert d["code"] == "RC505" and message in d["message"] and d["span"]["line"] == 2


def test_bad_names_leave_junit_and_sarif_valid_and_list_nothing_as_passed(here) -> None:
    (here / "reconf.toml").write_text('never-degrade = ["detectt"]\n', encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT, fmt="junit")
    assert code == 2
    root = ET.fromstring(out)
    assert root.get("errors") == "1" and "detectt" in out
    assert not [tc for tc in root.iter("testcase") if tc.find("error") is None and tc.find("failure") is None]
    code, out, _ = gate("--base", CHATTER, "--head", REDUNDANT, fmt="sarif")
    assert code == 2
    (r,) = validate_sarif(out)["runs"][0]["results"]
    assert r["ruleId"] == "RC508"
    assert r["locations"][0]["physicalLocation"]["region"] == {"startLine": 1, "startColumn": 18, "endLine": 1,
                                                               "endColumn": 27}


def test_text_output_shows_the_policy_line(here) -> None:
    (here / "reconf.toml").write_text('never-degrade = ["detectt"]\n', encoding="utf-8")
    code, _, err = gate("--base", CHATTER, "--head", REDUNDANT, fmt="text")
    assert code == 2
    assert "reconf.toml:1:18: error[RC508]" in err and '1 | never-degrade = ["detectt"]' in err


def test_pyproject_keys_are_found_in_their_table_only(here) -> None:
    (here / "pyproject.toml").write_text('[tool.other]\nkeep-ftm = 1\n\n[tool.reconf]\nkeep-ftm = 1\n',
                                         encoding="utf-8")
    code, out, _ = gate("--base", CHATTER, "--head", CHATTER)
    assert code == 2
    (d,) = diagnostics(out)
    assert d["span"]["file"] == "pyproject.toml" and d["span"]["line"] == 5


def test_reconf_toml_reads_both_places_and_refuses_a_key_given_twice(here) -> None:
    (here / "reconf.toml").write_text('max-disruption = 3\n[tool.reconf]\nstrategy = "paper"\n', encoding="utf-8")
    policy = load_policy()
    assert (policy.max_disruption, policy.strategy) == (3, "paper")
    (here / "reconf.toml").write_text('max-disruption = 3\n[tool.reconf]\nmax-disruption = 4\n', encoding="utf-8")
    with pytest.raises(DiagnosticError) as e:
        load_policy()
    assert e.value.diagnostics[0].span.line == 3


def test_allow_unsafe_base_is_read() -> None:
    from checker.gate.policy import parse_policy
    assert parse_policy({"allow-unsafe-base": True}, "p.toml").allow_unsafe_base is True
    assert parse_policy({}, "p.toml").allow_unsafe_base is False
    assert parse_policy({}, "p.toml").to_json()["allow-unsafe-base"] is False


def test_locate_strings_with_escapes_comments_and_several_lines() -> None:
    text = ('[tool.reconf]\nnever-degrade = [ "a\\"b", # one\n  \'c.d\',\n  """e""" ]\nkeep-ftm = true # all\n'
            '[tool.x]\nstrategy = "paper"\n')
    where = locate(text, "p.toml", ("tool.reconf",))
    assert set(where) == {"never-degrade", "keep-ftm"}
    nd = where["never-degrade"]
    assert [(s.line, s.col, s.end_col) for s in nd.entries] == [(2, 19, 25), (3, 3, 8), (4, 3, 10)]
    assert (nd.value.line, nd.value.col, nd.value.end_line, nd.value.end_col) == (2, 17, 4, 12)
    assert (where["keep-ftm"].value.col, where["keep-ftm"].value.end_col) == (12, 16)


def test_a_policy_that_is_a_device_is_refused_unread() -> None:
    """/dev/zero as the policy: bad input (RC505, why in the loader's words), not a read without end."""
    chatter = BY_NAME["chatter"].file
    r = CliRunner().invoke(main, ["gate", "--base", chatter, "--head", chatter, "--policy", "/dev/zero"])
    assert r.exit_code == 2 and "RC505" in r.stderr and "not a regular file" in r.stderr, r.output
