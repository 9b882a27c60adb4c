"""Producers of golden files, shared by the tests that compare and the script that regenerates."""
from __future__ import annotations

import glob
import os
import re
from typing import Callable, Iterator

from click.testing import CliRunner

from checker.cli.main import main

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.dirname(HERE)
ROOT = os.path.dirname(TESTS)


def bad_inputs() -> list[str]:
    return sorted(glob.glob(os.path.join(TESTS, "bad_inputs", "*.arch")))


def check_output(path: str) -> tuple[int, str]:
    """`reconf check` run from the repository root, so paths in messages are stable."""
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        result = CliRunner().invoke(main, ["check", "--engine", "python", os.path.relpath(path, ROOT)],
                                   env={"NO_COLOR": "1"})
    finally:
        os.chdir(cwd)
    # the summary's timing (`; in W s: ...`) differs on every run; test_check holds its form
    return result.exit_code, re.sub(r"; in \d+\.\d\d s: [^\n]*", "", result.stderr)


def diagnostics() -> Iterator[tuple[str, str]]:
    for p in bad_inputs():
        yield os.path.basename(p)[:-5] + ".txt", check_output(p)[1]


def unsafe_examples() -> Iterator[tuple[str, str]]:
    from tests.examples_table import EXAMPLES
    for ex in EXAMPLES:
        if not ex.safe:
            yield ex.name + ".txt", check_output(ex.file)[1]


def ros2_scripts() -> Iterator[tuple[str, str]]:
    from tests.test_ros_script import golden_scripts
    yield from golden_scripts()


GOLDEN_SETS: dict[str, Callable[[], Iterator[tuple[str, str]]]] = {
    "diagnostics": diagnostics,
    "explanations": unsafe_examples,
    "ros2": ros2_scripts,
}
