"""The README's examples run as written: every `reconf …` line of its fenced shell blocks (and
every `$ reconf …` line of its other fenced blocks) is run through bash, as from the repository
root, and must exit 0 with no traceback, or 1 where its comment says the example is unsafe.
A block just after a `<!-- live: ... -->` line needs a running ROS 2 graph: the live test it
names runs it (`tests/ros/test_live_readme.py`).

The commands run in a scratch copy of the repository's examples/ (a git repository on branch
`main`, for `git:main:…` revisions), so that the files they write (`-o plan.py`, `> x.arch`) and
rewrite (`reconf fmt`) are not the work tree's."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.examples_table import ROOT

README = os.path.join(ROOT, "README.md")
LIVE = "<!-- live:"
TIMEOUT = 300   # seconds for one command: a hang fails, a slow shared machine does not

# Commands that cannot run here, each with why. Keep this short.
SKIP = {
    # needs the run report of a plan script that failed against a live ROS 2 system
    "reconf recover run-report.json": "needs the report of a failed live run",
}


@dataclass(frozen=True)
class Example:
    line: int        # in README.md
    command: str     # as written, continuation lines joined
    unsafe: bool     # its comment says it is unsafe: exit 1 expected
    live: bool = False   # in a block marked `<!-- live: ... -->`

    @property
    def id(self) -> str:
        return f"L{self.line}:{self.command.split('#')[0].strip()[:70]}"


def examples(text: str) -> list[Example]:
    """Every reconf command line of the fenced blocks of `text`."""
    out: list[Example] = []
    fence: str | None = None
    live = False
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        opened = re.match(r"^(```+)\s*(\w*)\s*$", line)
        if fence is None and opened:
            fence = opened.group(2) or "-"
            live = i > 0 and lines[i - 1].startswith(LIVE)
        elif fence is not None and line.strip().startswith("```"):
            fence = None
        elif fence is not None:
            shell = fence in ("sh", "bash", "shell", "console")
            m = re.match(r"^\$ (reconf\s.*)$", line) or (re.match(r"^(reconf\s.*)$", line) if shell else None)
            if m:
                first, command = i + 1, m.group(1)
                while command.rstrip().endswith("\\") and i + 1 < len(lines):
                    i += 1
                    command = command.rstrip()[:-1] + " " + lines[i].strip()
                comment = command.split(" #", 1)[1] if " #" in command else ""
                out.append(Example(first, command, bool(re.search(r"\bunsafe\b", comment)), live))
        i += 1
    return out


with open(README, encoding="utf-8") as _f:
    EXAMPLES = examples(_f.read())


def test_the_readme_has_examples_of_every_command() -> None:
    said = {" ".join(e.command.split()[:2]) for e in EXAMPLES}
    for command in ("reconf check", "reconf alloy", "reconf verify-meta-model", "reconf plan", "reconf fmt", "reconf graph",
                    "reconf graph-plan", "reconf gate", "reconf ftm", "reconf recover", "reconf up", "reconf down",
                    "reconf discover", "reconf drift", "reconf modes"):
        assert command in said, command
    assert any(e.unsafe for e in EXAMPLES)


def test_the_skip_list_names_readme_commands() -> None:
    for prefix in SKIP:
        assert any(e.command.startswith(prefix) for e in EXAMPLES), f"{prefix!r} is no longer in the README"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scratch root: examples/ copied, committed on branch main."""
    root = tmp_path_factory.mktemp("readme")
    shutil.copytree(os.path.join(ROOT, "examples"), root / "examples")
    git = ["git", "-c", "user.name=reconf", "-c", "user.email=reconf@example.invalid", "-c", "init.defaultBranch=main"]
    for args in (["init", "-q", "-b", "main"], ["add", "."], ["commit", "-q", "-m", "examples"]):
        subprocess.run(git + args, cwd=root, check=True, capture_output=True)
    return root


# The commands whose default engine reaches Alloy (`--engine both`, or its plan verification);
# `verify-meta-model --unbounded` is z3's.
REACHES_ALLOY = re.compile(r"^reconf (check|verify-meta-model(?! --unbounded)|plan|gate|ftm select|up|down)\b")


def needs_alloy(example: Example) -> bool:
    return bool(REACHES_ALLOY.match(example.command)) and not re.search(r"--engine python|--no-alloy",
                                                                          example.command)


@pytest.mark.parametrize("example", [pytest.param(e, marks=[pytest.mark.alloy] if needs_alloy(e) else [])
                                     for e in EXAMPLES if not e.live], ids=lambda e: e.id)
def test_the_example_runs(example: Example, workdir: Path) -> None:
    for prefix, why in SKIP.items():
        if example.command.startswith(prefix):
            pytest.skip(why)
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env.pop("RECONF_DEBUG", None)
    done = subprocess.run(["bash", "-c", example.command], cwd=workdir, env=env, capture_output=True, text=True,
                          timeout=TIMEOUT)
    said = f"README.md:{example.line}: {example.command}\nstdout:\n{done.stdout[-3000:]}\nstderr:\n{done.stderr[-3000:]}"
    assert "Traceback" not in done.stdout + done.stderr, said
    assert done.returncode == (1 if example.unsafe else 0), said


@pytest.mark.alloy
def test_the_shown_plan_is_what_reconf_prints(workdir: Path) -> None:
    """The README's `$ reconf plan replace …` block shows the plan reconf prints (timings aside)."""
    with open(README, encoding="utf-8") as f:
        text = f.read()
    block = text[text.index("$ reconf plan replace talker"):]
    block = block[:block.index("```")]
    command, *shown = block.splitlines()
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    done = subprocess.run(["bash", "-c", command[2:]], cwd=workdir, env=env, capture_output=True, text=True,
                          timeout=TIMEOUT)
    printed = [" ".join(ln.split()) for ln in done.stderr.splitlines()]
    for line in shown:
        words = " ".join(line.split())
        if words and "..." not in words:
            assert words in printed, (words, done.stderr)
