"""What the gate and pre-commit hook tests share: `reconf gate` through click, `git` in a test's
repository, and a chatter system split over three files (`SPLIT`) to write into one."""
from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Union

from click.testing import CliRunner

from checker.cli.main import main


def gate(*args: str, fmt: str = "json", engine: str = "python") -> tuple[int, str, str]:
    result = CliRunner().invoke(main, ["gate", *args, "--output-format", fmt, "--engine", engine])
    return result.exit_code, result.stdout, result.stderr


def git(cwd: Union[str, Path], *args: str) -> str:
    return subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@example.org", "-c", "commit.gpgsign=false",
                           *args], cwd=cwd, check=True, capture_output=True, text=True).stdout


def write_tree(root: Path, files: dict[str, str]) -> None:
    """Each relative path with its text, directories made as needed."""
    for path, text in files.items():
        (root / path).parent.mkdir(parents=True, exist_ok=True)
        (root / path).write_text(text, encoding="utf-8")


MESSAGES = "message String = std_msgs/msg/String\n"
NODES = """include "../common/messages.arch"

component talker {
  output out: String
  functionality talk (out) {
    normal { out: String @ RATE }
    degraded { out: nothing }
  }
}

component listener {
  input in: String @ 10 Hz
  functionality listen (in) {
    normal { assume String @ 10 Hz }
    degraded { }
  }
}
"""
ROBOT = """system chatter
include "parts/nodes.arch"

topic /chatter: String @ 10 Hz {
  talker.out -> listener.in
}
"""
# sys/robot.arch includes sys/parts/nodes.arch, which includes sys/common/messages.arch (safe: 10 Hz)
SPLIT = {"sys/robot.arch": ROBOT, "sys/parts/nodes.arch": NODES.replace("RATE", "10 Hz"),
         "sys/common/messages.arch": MESSAGES}
