"""Inputs that a file of tests/bad_inputs cannot express: devices, FIFOs, sockets, symlinks,
include chains written on the fly, standard input, and inputs sized to exhaust memory or the
stack. Each runs the real command line in a process of its own, with a timeout and 1 GiB of
address space, and must end with exit 2 and its diagnostic: never a traceback, never RC000."""
from __future__ import annotations

import json
import os
import resource
import socket
import subprocess
import sys
from pathlib import Path
from typing import Callable, Optional

import pytest

from reconf_dsl import loader
from reconf_dsl.diagnostics import DiagnosticError

ROOT = Path(__file__).resolve().parent.parent
MEMORY = 1 << 30
MESSAGE = "system s\nmessage String = std_msgs/msg/String\n"
VALID = MESSAGE + """component talker {
  output out: String
  functionality talk (out) {
    normal { out: String @ 10 Hz }
    degraded { out: nothing }
  }
}
"""


def _bounded() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def reconf(*args: str, cwd: Optional[Path] = None, stdin: Optional[int] = None, input: Optional[str] = None,
           env: Optional[dict[str, str]] = None, code: str = "") -> subprocess.CompletedProcess[str]:
    """`reconf ARGS` in a fresh, memory-bounded process; `code` runs before the command line does."""
    environ = {k: v for k, v in os.environ.items() if k not in ("RECONF_ALLOW_INCLUDES_OUTSIDE", "RECONF_DEBUG")}
    environ.update({"NO_COLOR": "1", "PYTHONPATH": str(ROOT)}, **(env or {}))
    program = f"{code}\nfrom checker.cli.main import main\nmain()"
    return subprocess.run([sys.executable, "-c", program, *args], cwd=cwd or ROOT, stdin=stdin, input=input,
                          capture_output=True, text=True, timeout=120, env=environ, preexec_fn=_bounded)


def check(*args: str, **kw: object) -> subprocess.CompletedProcess[str]:
    return reconf("check", "--engine", "python", *args, **kw)  # type: ignore[arg-type]


def refused(proc: subprocess.CompletedProcess[str], code: str) -> str:
    out = proc.stdout + proc.stderr
    assert proc.returncode == 2, out
    assert f"error[{code}]" in out or f'"code": "{code}"' in out, out
    assert "Traceback" not in out and "RC000" not in out, out
    return out


# ---------------------------------------------------------------- what is not a regular file

def test_dev_zero_named_is_refused_unread() -> None:
    out = refused(check("/dev/zero"), "RC014")
    assert "/dev/zero is a character device, not a regular file" in out


def test_dev_zero_included_is_refused_even_when_outside_is_allowed(tmp_path: Path) -> None:
    top = tmp_path / "top.arch"
    top.write_text(MESSAGE + 'include "/dev/zero"\n')
    out = refused(check(str(top)), "RC016")                       # outside the tree: not even looked at
    assert "include of /dev/zero refused" in out
    out = refused(reconf("--allow-includes-outside", "check", "--engine", "python", str(top)), "RC014")
    assert f"{top}:3:1: error[RC014]" in out                      # at the include statement


def test_fifo_is_refused_without_waiting_for_a_writer(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.arch"
    os.mkfifo(fifo)
    refused(check(str(fifo)), "RC014")
    top = tmp_path / "top.arch"
    top.write_text(MESSAGE + 'include "pipe.arch"\n')
    out = refused(check(str(top)), "RC014")
    assert "pipe.arch is a FIFO (named pipe)" in out


def test_socket_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "s.arch"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.bind(str(path))
        out = refused(check(str(path)), "RC014")
    assert "is a socket" in out


def test_file_over_the_limit_is_refused_by_its_size(tmp_path: Path) -> None:
    big = tmp_path / "big.arch"
    with open(big, "wb") as f:                                    # sparse: nothing is written
        f.truncate(loader.MAX_FILE_BYTES + 1)
    out = refused(check(str(big)), "RC010")
    assert f"is {loader.MAX_FILE_BYTES + 1} bytes" in out


def test_files_of_one_load_share_one_budget(tmp_path: Path) -> None:
    for name in ("a", "b", "c"):
        (tmp_path / f"{name}.arch").write_text("// " + "x" * 1000 + "\n")
    (tmp_path / "top.arch").write_text(MESSAGE + 'include "a.arch"\ninclude "b.arch"\ninclude "c.arch"\n')
    # the same command line, with a budget of 2,500 bytes in place of 128 MiB
    proc = check(str(tmp_path / "top.arch"), code="import reconf_dsl.loader as l; l.MAX_TOTAL_BYTES = 2500")
    out = refused(proc, "RC015")
    assert "top.arch:5:1: error[RC015]" in out and "c.arch is not read" in out


def test_budget_counts_every_file_in_process(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "a.arch").write_text("// " + "x" * 100 + "\n")
    (tmp_path / "top.arch").write_text(MESSAGE + 'include "a.arch"\n')
    monkeypatch.setattr(loader, "MAX_TOTAL_BYTES", len(MESSAGE) + 60)
    with pytest.raises(DiagnosticError) as e:
        loader.load([str(tmp_path / "top.arch")])
    assert [d.code for d in e.value.diagnostics] == ["RC015"]


# ---------------------------------------------------------------- includes outside the tree

def test_symlink_leading_outside_is_refused_and_not_shown(tmp_path: Path) -> None:
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-LINE\n")
    inner = tmp_path / "project"
    inner.mkdir()
    (inner / "messages.arch").symlink_to(secret)
    (inner / "top.arch").write_text(MESSAGE + 'include "messages.arch"\n')
    out = refused(check(str(inner / "top.arch")), "RC016")
    assert f"(it resolves to {secret})" in out
    assert "TOP-SECRET-LINE" not in out
    out = refused(check("--output-format", "sarif", str(inner / "top.arch")), "RC016")
    assert "TOP-SECRET-LINE" not in out


def test_dotdot_leading_outside_is_refused(tmp_path: Path) -> None:
    (tmp_path / "common.arch").write_text("message Image = sensor_msgs/msg/Image\n")
    inner = tmp_path / "project"
    inner.mkdir()
    (inner / "top.arch").write_text(MESSAGE + 'include "sub/../../common.arch"\n')
    refused(check(str(inner / "top.arch")), "RC016")


def test_includes_outside_can_be_allowed(tmp_path: Path) -> None:
    (tmp_path / "common.arch").write_text("message Image = sensor_msgs/msg/Image\n")
    inner = tmp_path / "project"
    inner.mkdir()
    (inner / "top.arch").write_text(VALID + 'include "../common.arch"\n')
    proc = reconf("--allow-includes-outside", "check", "--engine", "python", str(inner / "top.arch"))
    assert proc.returncode == 0, proc.stderr
    proc = check(str(inner / "top.arch"), env={"RECONF_ALLOW_INCLUDES_OUTSIDE": "1"})
    assert proc.returncode == 0, proc.stderr
    refused(check(str(inner / "top.arch"), env={"RECONF_ALLOW_INCLUDES_OUTSIDE": "0"}), "RC016")


def test_includes_below_the_named_file_are_followed(tmp_path: Path) -> None:
    (tmp_path / "common").mkdir()
    (tmp_path / "common" / "more.arch").write_text("message Image = sensor_msgs/msg/Image\n")
    (tmp_path / "common" / "messages.arch").write_text('include "more.arch"\n')
    (tmp_path / "top.arch").write_text(VALID + 'include "common/messages.arch"\n')
    proc = check(str(tmp_path / "top.arch"))
    assert proc.returncode == 0, proc.stderr


# ---------------------------------------------------------------- depth

def _chain(directory: Path, n: int) -> Path:
    """c0.arch includes c1.arch, … up to c{n}.arch."""
    directory.mkdir()
    for i in range(n + 1):
        head = MESSAGE if i == 0 else ""
        tail = f'include "c{i + 1}.arch"\n' if i < n else ""
        (directory / f"c{i}.arch").write_text(head + tail)
    return directory / "c0.arch"


def test_include_chain_1500_deep_stops_at_the_limit(tmp_path: Path) -> None:
    out = refused(check(str(_chain(tmp_path / "chain", 1500))), "RC017")
    limit = loader.MAX_INCLUDE_DEPTH
    assert f"c{limit}.arch:1:1: error[RC017]: includes nest more than {limit} deep" in out


def test_include_chain_at_the_limit_is_read(tmp_path: Path) -> None:
    proc = check(str(_chain(tmp_path / "chain", loader.MAX_INCLUDE_DEPTH)))
    assert proc.returncode == 0, proc.stderr
    refused(check(str(_chain(tmp_path / "longer", loader.MAX_INCLUDE_DEPTH + 1))), "RC017")


def _nested_ftm(depth: int) -> str:
    return MESSAGE + "component c {\n  ftm " + "PBR(" * depth + "TR" + ")" * depth + "\n}\n"


@pytest.mark.parametrize("command", ["check", "fmt"])
def test_ftm_nested_1000_deep(tmp_path: Path, command: str) -> None:
    path = tmp_path / "deep.arch"
    path.write_text(_nested_ftm(1000))
    args = ("check", "--engine", "python") if command == "check" else ("fmt", "--check")
    out = refused(reconf(*args, str(path)), "RC018")
    col = len("  ftm ") + 4 * 64 + 4              # the 65th '(' of the line
    assert f"deep.arch:4:{col}: error[RC018]: more than 64 nested parentheses" in out
    assert path.read_text() == _nested_ftm(1000)  # fmt changed nothing


def test_ftm_nested_at_the_limit_is_parsed(tmp_path: Path) -> None:
    path = tmp_path / "deep.arch"
    path.write_text(_nested_ftm(64))
    out = (proc := check(str(path))).stderr
    assert proc.returncode == 1 and "RC018" not in out and "RC000" not in out, out  # the FTM rules object


N = 100_000
BIG = 16 << 20   # enough for a backtracking regular expression to need over 1 GiB
DEEP: dict[str, Callable[[], str]] = {
    "parentheses": lambda: MESSAGE + "component c {\n  ftm A" + "(" * N + "\n}\n",
    "braces": lambda: MESSAGE + "component c " + "{" * N + "}" * N + "\n",
    "block comments": lambda: MESSAGE + "/*" * N + "*/" * N + "\n",
    # the error is on a line of its own, so that the caret snippet is not the huge line
    "unterminated block comment": lambda: MESSAGE + "/*\n" + "x" * BIG + "\n",
    "huge string": lambda: MESSAGE + 'component c { run "' + "x" * BIG + '"\n x }\n',
    "huge string of escapes": lambda: MESSAGE + 'component c { run "' + "\\t" * (BIG // 16) + '"\n x }\n',
    "huge ROS name": lambda: MESSAGE + "topic " + "/a" * (BIG // 2) + ": String {\n x }\n",
    "huge message type": lambda: MESSAGE + "message M = " + "a/" * (BIG // 2) + "b\n x\n",
    "rates": lambda: MESSAGE + "environment e: String" + " @ 1 Hz" * N + "\n",
    "exponent": lambda: MESSAGE + "environment e: String @ 1e999999999 Hz\n",
    "criticality": lambda: MESSAGE + "component c { functionality f () criticality " + "9" * 5000 + " { } }\n",
    "resource": lambda: MESSAGE + "host h { cpus: " + "9" * 5000 + " }\n",
}
EXPECTED = {"parentheses": "RC001", "braces": "RC001", "block comments": "RC002",
            "unterminated block comment": "RC004", "huge string": "RC001", "huge string of escapes": "RC001",
            "huge ROS name": "RC001", "huge message type": "RC001", "rates": "RC001", "exponent": "RC113",
            "criticality": "RC119", "resource": "RC125"}
READ_LATER = {"RC113", "RC119", "RC125"}  # judged when read or resolved, not when formatted


@pytest.mark.parametrize("name", sorted(DEEP))
def test_deep_or_huge_constructs_are_diagnosed(tmp_path: Path, name: str) -> None:
    path = tmp_path / "deep.arch"
    path.write_text(DEEP[name]())
    refused(check("--output-format", "json", str(path)), EXPECTED[name])
    if EXPECTED[name] not in READ_LATER:
        refused(reconf("fmt", "--check", str(path)), EXPECTED[name])


# ---------------------------------------------------------------- standard input

def test_stdin_is_read_with_includes_from_the_current_directory() -> None:
    with open(ROOT / "examples" / "robot.arch") as f:
        proc = check("-", cwd=ROOT / "examples", stdin=f.fileno())
    assert proc.returncode == 0, proc.stderr
    assert "safe: robot" in proc.stderr


def test_stdin_diagnostics_name_stdin() -> None:
    proc = check("--output-format", "json", "-", input="system s\ncomponent c { x }\n")
    refused(proc, "RC001")
    span = json.loads(proc.stdout)["diagnostics"][0]["span"]
    assert (span["file"], span["line"], span["column"]) == ("<stdin>", 2, 15)
    text = check("-", input="system s\ncomponent c { x }\n")             # people see the position too
    assert "<stdin>:2:15: error[RC001]" in text.stderr and "component c { x }" in text.stderr, text.stderr


def test_stdin_includes_stay_in_the_current_directory(tmp_path: Path) -> None:
    (tmp_path / "x.arch").write_text("message Image = sensor_msgs/msg/Image\n")
    (tmp_path / "here").mkdir()
    out = refused(check("-", cwd=tmp_path / "here", input=MESSAGE + 'include "../x.arch"\n'), "RC016")
    assert "the current directory" in out


def test_stdin_has_the_same_budget() -> None:
    with open("/dev/zero", "rb") as zero:
        out = refused(check("-", stdin=zero.fileno()), "RC010")
    assert "<stdin> holds more" in out


def test_empty_stdin() -> None:
    refused(check("-", input=""), "RC006")


def test_a_megabyte_line_is_shown_around_the_caret(tmp_path: Path) -> None:
    """Neither the snippet nor the message echoes a whole line or token of a megabyte."""
    path = tmp_path / "long.arch"
    path.write_text("system s\ncomponent c { " + "x" * 1_000_000 + " }\n", encoding="utf-8")
    out = refused(check(str(path)), "RC001")
    assert len(out) < 2_000 and "long.arch:2:15: error[RC001]: unexpected 'xxx" in out and "…" in out


def test_a_resource_of_other_digits_is_refused(tmp_path: Path) -> None:
    """`²` is a digit to str.isdigit() but not to int(): RC125, not an internal error."""
    path = tmp_path / "sup.arch"
    path.write_text("system s\nhost h { cpus: ² }\n", encoding="utf-8")
    refused(check(str(path)), "RC125")
