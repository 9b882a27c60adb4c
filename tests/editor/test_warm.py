"""`reconf check` through a warm analyzer (`reconf daemon`): the same output and exit code as a
cold run, the timing line saying which ran it; cold again once the daemon is stopped."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator

import pytest

from tests.examples_table import ROOT

RECONF = os.path.join(os.path.dirname(sys.executable), "reconf")


@pytest.fixture
def daemon(tmp_path: Path) -> Iterator[dict[str, str]]:
    env = dict(os.environ, RECONF_SOCKET=str(tmp_path / "warm.sock"), RECONF_NO_PROGRESS="1")
    env.pop("RECONF_NO_WARM", None)
    proc = subprocess.Popen([RECONF, "daemon", "run"], env=env, cwd=tmp_path, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "warm.sock").exists():
            assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read() if proc.stderr else ""
            time.sleep(0.05)
        yield env
    finally:
        subprocess.run([RECONF, "daemon", "stop"], env=env, capture_output=True, timeout=60)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def run(env: dict[str, str], *args: str, cold: bool = False) -> subprocess.CompletedProcess[str]:
    e = dict(env, RECONF_NO_WARM="1") if cold else env
    return subprocess.run([RECONF, *args], env=e, cwd=ROOT, capture_output=True, text=True, timeout=300)


def _untimed(stderr: str) -> str:
    return re.sub(r"; in [0-9.]+ s: .*$", "", stderr.strip(), flags=re.MULTILINE)


@pytest.mark.parametrize("args", [
    ["check", "--engine", "python", "examples/chatter_slow.arch"],
    ["check", "--engine", "python", "examples/robot.arch", "--output-format", "sarif"],
    ["check", "--engine", "python", "tests/bad_inputs/unterminated_string.arch"],
    ["check", "--engine", "python", "no/such.arch"],
    ["check", "--no-such-option", "examples/chatter.arch"],
    ["--allow-includes-outside", "check", "--engine", "python", "examples/"],
], ids=["unsafe", "sarif", "syntax", "missing", "usage", "directory"])
def test_warm_and_cold_say_the_same(daemon: dict[str, str], args: list[str]) -> None:
    cold, warm = run(daemon, *args, cold=True), run(daemon, *args)
    assert warm.returncode == cold.returncode, (cold.stderr, warm.stderr)
    assert warm.stdout == cold.stdout
    assert _untimed(warm.stderr) == _untimed(cold.stderr)
    if "; in " in cold.stderr:
        assert "(cold)" in cold.stderr and re.search(r"start-up [0-9.]+ \(warm: reconf daemon, pid \d+\)", warm.stderr)


def test_json_says_which_analyzer(daemon: dict[str, str]) -> None:
    args = ["check", "--engine", "python", "examples/chatter.arch", "--output-format", "json"]
    cold, warm = json.loads(run(daemon, *args, cold=True).stdout), json.loads(run(daemon, *args).stdout)
    assert cold["analyzer"] == "cold" and warm["analyzer"].startswith("warm: reconf daemon, pid")
    for doc in (cold, warm):
        doc.pop("analyzer"), doc.pop("timing"), doc["engines"]["python"].pop("seconds")
    assert warm == cold


@pytest.mark.alloy
def test_the_alloy_proof_warm(daemon: dict[str, str]) -> None:
    cold, warm = run(daemon, "check", "examples/chatter_slow.arch", cold=True), run(daemon, "check", "examples/chatter_slow.arch")
    assert warm.returncode == cold.returncode == 1
    assert _untimed(warm.stderr) == _untimed(cold.stderr)
    assert "Alloy start 0.00" in warm.stderr or "Alloy start 0.01" in warm.stderr, warm.stderr


def test_stopped_means_cold(daemon: dict[str, str]) -> None:
    assert "warm: reconf daemon" in run(daemon, "check", "--engine", "python", "examples/chatter.arch").stderr
    stopped = subprocess.run([RECONF, "daemon", "stop"], env=daemon, capture_output=True, text=True, timeout=60)
    assert stopped.returncode == 0 and "stopped" in stopped.stderr
    assert "(cold)" in run(daemon, "check", "--engine", "python", "examples/chatter.arch").stderr
    status = subprocess.run([RECONF, "daemon", "status"], env=daemon, capture_output=True, text=True, timeout=60)
    assert status.returncode == 0 and "no warm analyzer" in status.stderr
