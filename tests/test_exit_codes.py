"""The exit-code contract of docs/exit-codes.md, command by command, under each class of failure:
a missing file, a file that does not parse, an unknown option, an unsafe architecture, an output
that cannot be written, and a JVM that cannot start (a heap too small), in machine formats too."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from tests.examples_table import BY_NAME

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CHATTER = BY_NAME["chatter"].file
SLOW = os.path.join(ROOT, "examples", "chatter_slow.arch")
MIGRATED = os.path.join(ROOT, "examples", "chatter_migrated.arch")
FTM = os.path.join(ROOT, "examples", "ftm", "client_server_pbr.arch")
BROKEN = os.path.join(HERE, "bad_inputs", "unterminated_string.arch")
MISSING = os.path.join(HERE, "no_such_file.arch")

# every command, with {f} where its architecture goes (and {g} a second one)
COMMANDS: dict[str, list[str]] = {
    "check": ["check", "--engine", "python", "{f}"],
    "alloy": ["alloy", "{f}"],
    "fmt": ["fmt", "--check", "{f}"],
    "graph": ["graph", "--format", "mermaid", "{f}"],
    "graph-plan": ["graph-plan", "--format", "mermaid", "{f}", "{g}"],
    "plan replace": ["plan", "replace", "talker", "-f", "{f}", "--no-alloy"],
    "plan remove": ["plan", "remove", "talker", "-f", "{f}", "--no-alloy"],
    "plan migrate": ["plan", "migrate", "{f}", "{g}", "--no-alloy"],
    "plan add": ["plan", "add", "logger", "--from", "{g}", "-f", "{f}", "--no-alloy"],
    "plan transition": ["plan", "transition", "server", "PBR", "-f", "{f}", "--no-alloy"],
    "plan verify": ["plan", "verify", os.path.join(ROOT, "examples", "plans", "replace_talker.json"), "-f", "{f}",
                    "--engine", "python"],
    "gate": ["gate", "--base", "{f}", "--head", "{g}"],
    "ftm expand": ["ftm", "expand", "{f}"],
    "ftm select": ["ftm", "select", "server", "-f", "{f}", "--no-alloy"],
    "up": ["up", "{f}", "--no-alloy", "--dry-run"],
    "down": ["down", "{f}", "--no-alloy", "--dry-run"],
    "modes export": ["modes", "export", "{f}"],
}
JSON = {"check", "plan replace", "plan remove", "plan migrate", "plan add", "plan transition", "plan verify", "ftm select", "up",
        "down"}
# commands that take no architecture: only the failures that apply to them
OTHERS: dict[str, list[str]] = {"recover": ["recover", "{f}"], "timeline": ["timeline", "{f}"],
                                "verify-meta-model": ["verify-meta-model", "--scope", "2"],
                                "lsp": ["lsp", "--stdio"], "daemon status": ["daemon", "status"]}


def args(name: str, f: str, g: str = MIGRATED) -> list[str]:
    return [a.format(f=f, g=g) for a in COMMANDS[name]]


def invoke(argv: list[str]):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, argv)


def assert_clean(r, code: int) -> None:  # type: ignore[no-untyped-def]
    text = r.stdout + r.stderr
    assert r.exit_code == code, text
    assert "Traceback" not in text and "RC000" not in text, text
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_a_missing_file_is_2(name: str) -> None:
    r = invoke(args(name, MISSING, MISSING))
    assert_clean(r, 2)
    assert "no_such_file.arch" in r.stderr


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_a_file_that_does_not_parse_is_2(name: str) -> None:
    r = invoke(args(name, BROKEN, BROKEN))
    assert_clean(r, 2)
    assert "unterminated_string.arch:" in r.stderr and "RC003" in r.stderr


@pytest.mark.parametrize("name", sorted(JSON))
def test_bad_input_in_json_is_an_error_document(name: str) -> None:
    r = invoke(args(name, BROKEN, BROKEN) + ["--output-format", "json"])
    assert_clean(r, 2)
    doc = json.loads(r.stdout)
    assert doc["verdict"] == "error" and doc["diagnostics"][0]["code"] == "RC003"


@pytest.mark.parametrize("name", sorted(COMMANDS) + sorted(OTHERS))
def test_an_unknown_option_is_2(name: str) -> None:
    argv = args(name, CHATTER, CHATTER) if name in COMMANDS else [a.format(f=CHATTER) for a in OTHERS[name]]
    r = invoke(argv + ["--no-such-option"])
    assert_clean(r, 2)
    assert "No such option" in r.stderr and not r.stdout


@pytest.mark.parametrize("path, said", [(MISSING, "does not exist"), (CHATTER, "cannot read it as a run report")])
def test_recover_without_a_run_report_is_2(path: str, said: str) -> None:
    r = invoke(["recover", path])
    assert_clean(r, 2)
    assert said in r.stderr


@pytest.mark.parametrize("path, said", [(MISSING, "does not exist"), (CHATTER, "cannot read it as a run report")])
def test_timeline_without_a_run_report_is_2(path: str, said: str) -> None:
    r = invoke(["timeline", path])
    assert_clean(r, 2)
    assert said in r.stderr


@pytest.mark.parametrize("argv", [
    ["check", "--engine", "python", SLOW],
    ["plan", "remove", "talker", "-f", SLOW, "--no-alloy"],
    pytest.param(["gate", "--base", CHATTER, "--head", SLOW], marks=pytest.mark.alloy),   # the gate's engine: both
    ["up", SLOW, "--no-alloy", "--dry-run"],
    ["modes", "export", SLOW],
], ids=["check", "plan", "gate", "up", "modes-export"])
def test_unsafe_is_1(argv: list[str]) -> None:
    assert_clean(invoke(argv), 1)


@pytest.mark.parametrize("argv, said", [
    (["check", "--engine", "python", CHATTER, "--bag", MISSING], "RC701"),
    (["check", "--engine", "python", CHATTER, "--bag", BROKEN], "RC701"),
    (["check", "--engine", "python", CHATTER, "--window", "2"], "--window is only read with --bag"),
    (["check", "--engine", "python", os.path.join(ROOT, "examples", "robot.arch"), "--bag",
      os.path.join(ROOT, "examples", "recordings", "chatter")], "RC706"),          # none of robot's topics in it
], ids=["missing", "not-a-recording", "window-alone", "judges-nothing"])
def test_a_recording_that_cannot_be_read_is_2(argv: list[str], said: str) -> None:
    r = invoke(argv)
    assert_clean(r, 2)
    assert said in r.stderr


def test_a_file_to_reformat_is_1_for_fmt_check(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "chatter.arch"
    with open(CHATTER, encoding="utf-8") as f:
        path.write_text(f.read().replace("\n", "\n\n\n", 3), encoding="utf-8")
    assert_clean(invoke(["fmt", "--check", str(path)]), 1)


@pytest.mark.parametrize("argv", [
    ["alloy", CHATTER, "-o", "{out}"],
    ["graph", CHATTER, "--format", "dot", "-o", "{out}"],
    ["plan", "replace", "talker", "-f", CHATTER, "--no-alloy", "-o", "{out}"],
    ["ftm", "expand", FTM, "-o", "{out}"],
    ["up", CHATTER, "--no-alloy", "-o", "{out}"],
    ["modes", "export", CHATTER, "-o", "{out}"],
], ids=["alloy", "graph", "plan", "ftm-expand", "up", "modes-export"])
@pytest.mark.parametrize("where", ["missing-dir", "parent-is-a-file"])
def test_an_output_that_cannot_be_written_is_2_and_names_it(argv: list[str], where: str, tmp_path) -> None:  # type: ignore[no-untyped-def]
    if where == "missing-dir":
        out = str(tmp_path / "no" / "such" / "dir" / "out.txt")
    else:                                   # fails for root too, unlike a read-only directory
        (tmp_path / "file").write_text("x")
        out = str(tmp_path / "file" / "out.txt")
    ext = {"alloy": ".als", "graph": ".dot", "plan": ".py", "ftm": ".arch", "up": ".py", "modes": ".yaml"}[argv[0]]
    out = out.replace(".txt", ext)
    r = invoke([a.format(out=out) for a in argv])
    assert_clean(r, 2)
    assert out in r.stderr and ".reconf-" not in r.stderr, r.stderr
    assert not os.path.exists(out)


@pytest.mark.alloy
@pytest.mark.parametrize("argv, json_out", [
    (["check", CHATTER, "--output-format", "sarif"], True),
    (["check", CHATTER, "--output-format", "json"], True),
    (["plan", "replace", "talker", "-f", CHATTER, "--output-format", "json"], True),
    (["gate", "--base", CHATTER, "--head", MIGRATED], False),
    (["verify-meta-model", "--output-format", "json"], True),
], ids=["check-sarif", "check-json", "plan-json", "gate", "verify-meta-model"])
def test_a_jvm_that_cannot_start_is_2_with_valid_output(argv: list[str], json_out: bool) -> None:
    """A heap the JVM would die of (it ends the process as it starts, exit 1, nothing written)."""
    env = dict(os.environ, RECONF_ALLOY_XMX="1k")
    env.pop("RECONF_DEBUG", None)
    reconf = os.path.join(os.path.dirname(sys.executable), "reconf")
    r = subprocess.run([reconf, *argv], env=env, capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "RECONF_ALLOY_XMX=1k" in r.stdout + r.stderr and "RC301" in r.stdout + r.stderr
    assert "Traceback" not in r.stderr and "RC000" not in r.stdout + r.stderr
    if json_out:
        json.loads(r.stdout)                                # SARIF and JSON both parse as JSON


def test_unsafe_machine_output_says_so(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Exit 1 and the document's verdict agree: never an "error" verdict with the unsafe exit."""
    unprotected = tmp_path / "unprotected.arch"
    with open(FTM, encoding="utf-8") as f:
        text = f.read()
    unprotected.write_text(text[:text.index("\nservice ")] + "\n", encoding="utf-8")   # its one service, the last item
    cases = [(["check", "--engine", "python", SLOW], "unsafe"),
             (["plan", "remove", "talker", "-f", SLOW, "--no-alloy"], "no-plan"),
             (["plan", "migrate", FTM, str(unprotected), "--no-alloy"], "unsafe")]       # RC407: nothing to protect
    for argv, verdict in cases:
        r = invoke(argv + ["--output-format", "json"])
        assert_clean(r, 1)
        assert json.loads(r.stdout)["verdict"] == verdict, (argv, r.stdout)


def test_a_former_command_name_still_answers_and_help_lists_only_the_new_one() -> None:
    from checker.cli.main import FORMER_NAMES
    listed = CliRunner().invoke(main, ["--help"]).output
    for former, name in FORMER_NAMES.items():
        assert former not in listed.replace(name, "") and name in listed
        res = CliRunner().invoke(main, [former, "--help"])
        assert res.exit_code == 0 and f"Usage: main {name}" in res.output.replace(former, name), res.output
