"""The corpus of malformed inputs, and a table of cases per diagnostic code: every code an
architecture file can give has a case here (a file of tests/bad_inputs/ or a text below) with the
code and its line:col, every diagnostic a case gives is listed, and a code of the registry
(reconf_dsl/codes.py) with no case is named in NOT_FROM_A_FILE with the reason. Never a
traceback, never an internal error. Golden files hold the exact text (`python -m
tests.regen_golden`)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from reconf_dsl import codes
from tests.golden import GOLDEN_SETS, HERE, ROOT, bad_inputs, check_output
from tests.support.ftm import client_server

HEADER = re.compile(r"^(?P<file>[^:\n]+):(?P<line>\d+):(?P<col>\d+): (?P<level>error|warning)"
                    r"\[(?P<code>RC\d{3})\]: .+", re.M)

# Each file of tests/bad_inputs/ (without `.arch`) with every diagnostic it gives, in order: the
# code and line:col in that file, or file:line:col when the place is in a file it includes.
BAD_INPUTS: dict[str, list[tuple[str, str]]] = {
    "degraded_assumes": [("RC111", "7:23")],
    "degraded_not_covered": [("RC112", "7:16")],
    "direction_mismatch": [("RC105", "17:26"), ("RC105", "17:41")],
    "duplicate_component": [("RC102", "10:1")],
    "duplicate_message": [("RC102", "3:1")],
    "duplicate_mode": [("RC110", "7:5")],
    "duplicate_port": [("RC102", "5:3")],
    "empty": [("RC006", "1:1")],
    "ftm_nested_too_deep": [("RC018", "12:36")],
    "functionality_unknown_port": [("RC107", "5:3")],
    "guarantee_not_output": [("RC108", "6:14")],
    "include_cycle_a": [("RC009", "include_cycle_b.arch.inc:1:1")],
    "include_missing": [("RC008", "2:1")],
    "include_outside_absolute": [("RC016", "3:1")],
    "include_outside_parent": [("RC016", "3:1")],
    "missing_degraded_mode": [("RC109", "5:3")],
    "negative_rate": [("RC113", "4:22")],
    "no_system": [("RC115", "1:1")],
    "non_utf8": [("RC005", "2:12")],
    "only_comments": [("RC115", "1:1")],
    "port_on_two_topics": [("RC123", "11:20")],
    "bad_takes": [("RC133", "5:23"), ("RC133", "5:46"), ("RC133", "6:16")],
    "takes_twice": [("RC133", "6:9")],
    "replaces_unknown": [("RC118", "3:1")],
    "service_two_servers": [("RC117", "17:36")],
    "single_two_publishers": [("RC116", "17:45")],
    "syntax_attachment": [("RC001", "17:37")],
    "syntax_component_brace": [("RC001", "4:3")],
    "syntax_environment": [("RC001", "3:20")],
    "syntax_ftm": [("RC001", "5:1")],
    "syntax_functionality_ports": [("RC001", "5:22")],
    "syntax_include": [("RC001", "2:9")],
    "syntax_input_pred": [("RC001", "4:13")],
    "syntax_message": [("RC001", "2:16")],
    "syntax_message_type": [("RC001", "2:18")],
    "syntax_mode_kind": [("RC001", "6:5")],
    "syntax_port": [("RC001", "4:14")],
    "syntax_portref": [("RC001", "17:33")],
    "syntax_rate": [("RC001", "6:28")],
    "syntax_resources": [("RC001", "4:20")],
    "syntax_service": [("RC001", "4:1")],
    "syntax_system": [("RC001", "2:1")],
    "syntax_topic": [("RC001", "10:16")],
    "two_systems": [("RC115", "3:1")],
    "type_mismatch": [("RC106", "11:24")],
    "unexpected_character": [("RC002", "3:20")],
    "unknown_component_ref": [("RC103", "10:26")],
    "unknown_fault": [("RC124", "3:1")],
    "unknown_ftm": [("RC124", "4:11")],
    "unknown_message": [("RC101", "4:3"), ("RC121", "6:19")],
    "unknown_message_in_predicate": [("RC101", "6:21")],
    "unknown_port_ref": [("RC104", "17:26")],
    "unknown_unit": [("RC114", "6:31")],
    "unterminated_comment": [("RC004", "3:1")],
    "unterminated_string": [("RC003", "4:7")],
    "zero_rate": [("RC113", "6:28")],
}

M = "system s\nmessage String = std_msgs/msg/String\n"
TALKER = ("component talker {\n  output out: String\n  functionality talk (out) {\n"
          "    normal { out: String @ %s }\n    degraded { out: nothing }\n  }\n}\n")
LISTENER = ("component listener {\n  input in: String @ 10 Hz\n  functionality listen (in) {\n"
            "    normal { assume String @ 10 Hz }\n    degraded { }\n  }\n}\n")
# A component that is not a reconf node (its `node` block), with the block's lines from line 5 on.
NODE = ("component talker {\n  node talker {\n%s\n  }\n  output out: String\n"
        "  functionality talk (out) { normal { out: String @ 10 Hz } degraded { out: nothing } }\n}\n")
# The client/server of tests/support/ftm.py: its `ftm` line is line 9 (10 with resources).
UNSERVED = "service /compute: Reply @ 10 Hz { server.reply -> client.reply }"


def include_chain(n: int) -> dict[str, str]:
    """c0.arch includes c1.arch, which includes c2.arch, ... down to c{n}.arch."""
    return {f"c{i}.arch": (M if i == 0 else "") + (f'include "c{i + 1}.arch"\n' if i < n else "")
            for i in range(n + 1)}


# Codes no file of tests/bad_inputs/ gives, each from a text (or files: the first is the one
# checked), with the exit code of `reconf check --engine python` (2: not read, 1: read and judged
# unsafe) and every diagnostic it gives, in order.
TEXTS: dict[str, tuple[str | dict[str, str], int, list[tuple[str, str]]]] = {
    "includes_33_deep": (include_chain(40), 2, [("RC017", "c32.arch:1:1")]),
    "criticality_not_whole": (M + "component c {\n  output out: String\n  functionality f (out) criticality 1.5 {\n"
                              "    normal { out: String @ 10 Hz }\n    degraded { }\n  }\n}\n", 2, [("RC119", "5:37")]),
    "version_attached": (M + TALKER % "10 Hz" + (TALKER % "10 Hz").replace("talker {", "talker_v2 replaces talker {")
                         + "topic /chatter: String { talker_v2.out -> }\n", 2, [("RC122", "17:26")]),
    "unknown_resource": (M + "host h { cpus: 1 disks: 2 }\n", 2, [("RC125", "3:18")]),
    "assume_nothing": (M + "component c {\n  input i: String\n  functionality f (i) {\n    normal { assume nothing }\n"
                       "    degraded { }\n  }\n}\n", 2, [("RC126", "6:21")]),
    "output_named_assume": (M + "component c {\n  output assume: String\n  functionality f (assume) {\n"
                            "    normal { }\n    degraded { }\n  }\n}\n", 2, [("RC127", "4:3")]),
    "node_unknown_port": (M + NODE % "    out = /chatter  extra = /x", 2, [("RC128", "5:21")]),
    "node_port_without_ros_name": (M + NODE % "", 2, [("RC129", "7:3")]),
    "node_deactivate_plain": (M + NODE % "    out = /chatter\n    talk degraded: deactivate", 2, [("RC130", "6:20")]),
    "node_parameter_in_one_mode": (M + NODE % "    out = /chatter\n    talk degraded: set rate = 0.0", 2,
                                   [("RC131", "6:20")]),
    "node_parameter_value": (M + NODE % "    out = /chatter\n    talk degraded: set on = maybe\n"
                                        "    talk normal: set on = true", 2, [("RC131", "6:29")]),
    "node_on_a_service": (M + NODE % "    out = /add" + "service /add: String { talker.out -> }\n", 2,
                          [("RC132", "10:24")]),
    "assumption_not_satisfied": (M + TALKER % "5 Hz" + LISTENER
                                 + "topic /chatter: String { talker.out -> listener.in }\n",
                                 1, [("RC201", "13:21")]),
    "ftm_misnested": (client_server("TR(PBR)"), 1, [("RC401", "9:7")]),
    "ftm_fault_not_covered": (client_server("PBR", faults="crash, transient", application="state_access"),
                              1, [("RC402", "9:7")]),
    "ftm_lfr_non_deterministic": (client_server("LFR", application="non_deterministic, state_access"),
                                  1, [("RC403", "9:7")]),
    "ftm_pbr_low_bandwidth": (client_server("SEC(PBR(TR))", faults="crash, transient, intrusion",
                                            resources="bandwidth: low"), 1, [("RC404", "10:11")]),
    "ftm_duplex_on_one_host": (client_server("LFR", hosts="master"), 1, [("RC406", "9:3"), ("RC405", "9:7")]),
    "ftm_nothing_to_protect": (client_server("PBR").replace(UNSERVED, ""), 1, [("RC407", "9:3"), ("RC201", "20:21")]),
}

# Registered codes with no case above, and why no architecture file gives them to `check`.
NOT_FROM_A_FILE: dict[str, str] = {
    "RC000": "an internal error: no input is meant to give it",
    "RC007": "no file at all (tests: test_missing_file_and_directory)",
    "RC010": "a file over 64 MiB (tests/test_hostile_inputs.py, with a sparse file)",
    "RC011": "Graphviz or z3 missing on the machine, not a property of the input",
    "RC012": "`graph --format svg` of a large picture: a command's option",
    "RC013": "`-o` contradicting `--format`: a command's options",
    "RC014": "a device, FIFO or socket: not a file with a text (tests/test_hostile_inputs.py)",
    "RC015": "128 MiB of files in one load (tests/test_hostile_inputs.py, with the budget lowered)",
    **{code: "`plan verify`: a plan document, not an architecture file (tests/test_plan_verify.py)"
       for code in ("RC304", "RC305", "RC306", "RC307", "RC308", "RC309")},
    "RC408": "`ftm expand` of a component without an FTM: a command's argument (tests/ftm/)",
    "RC409": "`ftm expand` into a name that is taken: the command's output, not the input (tests/ftm/)",
}
# Whole series that judge something else than an architecture file.
SERIES_NOT_FROM_A_FILE: dict[str, str] = {
    "RC3": "the Alloy engine (available, agreeing with Python, sized), not the input",
    "RC499": "the Alloy engine disagreeing on `reconf ftm`",
    "RC5": "`reconf gate`: two git revisions and a policy",
    "RC6": "a live ROS 2 graph (`discover`, `drift`) or an SMH YAML file (`modes`)",
    "RC7": "a rosbag2 recording (`check --bag`)",
}


def reported(text: str, checked: str) -> list[tuple[str, str]]:
    """Each diagnostic of `check`'s text: its code and line:col (file:line:col if not in `checked`)."""
    return [(m["code"], f"{m['line']}:{m['col']}" if os.path.basename(m["file"]) == checked
             else f"{os.path.basename(m['file'])}:{m['line']}:{m['col']}") for m in HEADER.finditer(text)]


def not_from_a_file(code: str) -> str | None:
    return NOT_FROM_A_FILE.get(code) or next((why for s, why in SERIES_NOT_FROM_A_FILE.items()
                                              if code.startswith(s)), None)


def test_corpus_is_large_enough() -> None:
    assert len(bad_inputs()) >= 30


def test_every_file_of_the_corpus_has_its_row() -> None:
    assert sorted(os.path.basename(p)[:-5] for p in bad_inputs()) == sorted(BAD_INPUTS)


@pytest.mark.parametrize("path", bad_inputs(), ids=lambda p: os.path.basename(p))
def test_bad_input_is_diagnosed(path: str) -> None:
    code, text = check_output(path)
    assert code == 2, text
    assert "Traceback" not in text
    assert reported(text, os.path.basename(path)) == BAD_INPUTS[os.path.basename(path)[:-5]], text
    assert all(m["file"].startswith("tests/bad_inputs/") for m in HEADER.finditer(text)), text


@pytest.mark.parametrize("name", sorted(TEXTS))
def test_text_is_diagnosed(name: str, tmp_path: Path) -> None:
    files, exit_code, expected = TEXTS[name]
    if isinstance(files, str):
        files = {f"{name}.arch": files}
    for file, text in files.items():
        (tmp_path / file).write_text(text, encoding="utf-8")
    first = next(iter(files))
    result = CliRunner().invoke(main, ["check", "--engine", "python", str(tmp_path / first)], env={"NO_COLOR": "1"})
    assert "Traceback" not in result.output
    assert reported(result.stderr, first) == expected, result.stderr
    assert result.exit_code == exit_code, result.stderr


def test_every_code_a_file_can_give_has_a_case() -> None:
    registered = [c.code for c in codes.CODES]
    cased = {code for rows in BAD_INPUTS.values() for code, _ in rows}
    cased |= {code for _, _, rows in TEXTS.values() for code, _ in rows}
    uncased = [c for c in registered if c not in cased and not_from_a_file(c) is None]
    assert uncased == [], "give each a case in BAD_INPUTS or TEXTS, or a reason in NOT_FROM_A_FILE"
    # an exemption names a registered code that truly has no case
    stale = sorted(c for c in NOT_FROM_A_FILE if c not in registered or c in cased)
    assert stale == [], "exempt in NOT_FROM_A_FILE, yet unregistered or with a case"
    assert sorted(c for c in cased if not_from_a_file(c) is not None) == [], "a case of a series said not to be"


@pytest.mark.parametrize("name", sorted(GOLDEN_SETS))
def test_golden(name: str) -> None:
    for key, text in GOLDEN_SETS[name]():
        golden = os.path.join(HERE, name, key)
        assert os.path.exists(golden), f"missing golden {golden}: run python -m tests.regen_golden"
        with open(golden, encoding="utf-8") as f:
            assert text == f.read(), f"{key} differs from its golden file"


def test_snippet_has_caret_under_the_problem() -> None:
    _, text = check_output(os.path.join(ROOT, "tests", "bad_inputs", "unknown_unit.arch"))
    lines = text.splitlines()
    assert lines[0].startswith("tests/bad_inputs/unknown_unit.arch:6:31: error[RC114]: unknown unit 'hertz'")
    src, caret = lines[1], lines[2]
    assert src.split("| ", 1)[1] == "    normal { out: String @ 10 hertz }"
    assert caret.index("^") == src.index("hertz") and caret.count("^") == len("hertz")


def test_five_megabyte_file_reports_position_quickly(tmp_path: "os.PathLike[str]") -> None:
    unit = "component c{i} {{\n  output out: String\n  functionality f (out) {{\n    normal {{ out: String @ 10 Hz }}\n    degraded {{ }}\n  }}\n}}\n"
    parts = ["system big\nmessage String = std_msgs/msg/String\n"]
    size, i = 0, 0
    while size < 5 * 1024 * 1024:
        chunk = unit.format(i=i)
        parts.append(chunk)
        size += len(chunk)
        i += 1
    parts.append("component broken { output out String }\n")
    path = os.path.join(str(tmp_path), "big.arch")
    with open(path, "w") as f:
        f.write("".join(parts))
    lines = "".join(parts).count("\n")
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "checker", "check", path], capture_output=True, text=True,
                          timeout=120)
    elapsed = time.perf_counter() - start
    assert proc.returncode == 2
    assert f"big.arch:{lines}:31: error[RC001]: unexpected 'String'" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert elapsed < 60


def test_missing_file_and_directory(tmp_path: "os.PathLike[str]") -> None:
    proc = subprocess.run([sys.executable, "-m", "checker", "check", os.path.join(str(tmp_path), "nope.arch")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "error[RC007]: no such file" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "checker", "check", "--output-format", "json",
                           os.path.join(str(tmp_path), "nope.arch")], capture_output=True, text=True)
    assert proc.returncode == 2 and '"code": "RC007"' in proc.stdout


def test_usage_error_exits_2() -> None:
    proc = subprocess.run([sys.executable, "-m", "checker", "check"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.splitlines()[-1] == "Error: Missing argument 'PATH...'." and proc.stdout == ""
    proc = subprocess.run([sys.executable, "-m", "checker", "frobnicate"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.splitlines()[-1] == "Error: No such command 'frobnicate'." and proc.stdout == ""
