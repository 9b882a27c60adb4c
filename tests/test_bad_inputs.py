"""The corpus of malformed inputs: each gives a positioned diagnostic with a stable code and exit 2,
never a traceback. Golden files hold the exact text (`python -m tests.regen_golden`)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import time

import pytest

from tests.golden import GOLDEN_SETS, HERE, ROOT, bad_inputs, check_output

HEADER = re.compile(r"^(?P<file>[^:\n]+):(?P<line>\d+):(?P<col>\d+): error\[(?P<code>RC\d{3})\]: .+", re.M)


def test_corpus_is_large_enough() -> None:
    assert len(bad_inputs()) >= 30


@pytest.mark.parametrize("path", bad_inputs(), ids=lambda p: os.path.basename(p))
def test_bad_input_is_diagnosed(path: str) -> None:
    code, text = check_output(path)
    assert code == 2, text
    assert "Traceback" not in text
    m = HEADER.search(text)
    assert m, text
    assert m["file"].startswith("tests/bad_inputs/")
    assert "RC000" not in text  # never an internal error


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
    proc = subprocess.run([sys.executable, "-m", "checker", "frobnicate"], capture_output=True, text=True)
    assert proc.returncode == 2
