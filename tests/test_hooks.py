"""The pre-commit hooks, run as pre-commit runs them: the `entry` of `.pre-commit-hooks.yaml`
with the staged .arch files appended, in a git repository made for the test."""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from checker.cli.hooks import roots_of
from checker.cli.main import main
from tests.examples_table import ROOT
from tests.support.gatekit import MESSAGES, NODES, SPLIT, git, write_tree

pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="git is not installed")

SOLO = """system solo

message String = std_msgs/msg/String

component talker {
  output out: String
  functionality talk (out) {
    normal { out: String @ 10 Hz }
    degraded { out: nothing }
  }
}
"""


def hook(hook_id: str) -> list[str]:
    with open(os.path.join(ROOT, ".pre-commit-hooks.yaml"), encoding="utf-8") as f:
        (entry,) = [h["entry"] for h in yaml.safe_load(f) if h["id"] == hook_id]
    return shlex.split(entry)


def run(repo: Path, hook_id: str, *args: str) -> subprocess.CompletedProcess[str]:
    """As pre-commit does: the entry, the hook's args, then the staged files; `python` is the
    hook environment's."""
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""),
               PYTHONPATH=ROOT, NO_COLOR="1")
    return subprocess.run([*hook(hook_id), *args], cwd=repo, env=env, capture_output=True, text=True, check=False)


@pytest.fixture
def repo(tmp_path) -> Path:
    r = tmp_path / "repo"
    write_tree(r, {**SPLIT, "other/solo.arch": SOLO, "lib/orphan.arch": MESSAGES})
    git(r, "init", "-q")
    git(r, "add", ".")
    git(r, "commit", "-q", "-m", "systems")
    return r


def test_an_included_file_is_checked_through_the_systems_that_include_it(repo) -> None:
    git(repo, "add", "sys/common/messages.arch")
    done = run(repo, "reconf-check", "--engine", "python", "sys/common/messages.arch")
    assert done.returncode == 0, done.stderr
    assert "RC115" not in done.stderr and "✓ safe: chatter" in done.stderr


def test_a_staged_include_that_breaks_its_system_fails_the_hook(repo) -> None:
    (repo / "sys/parts/nodes.arch").write_text(NODES.replace("RATE", "5 Hz"), encoding="utf-8")
    git(repo, "add", "sys/parts/nodes.arch")
    done = run(repo, "reconf-check", "--engine", "python", "sys/parts/nodes.arch", "other/solo.arch")
    assert done.returncode == 1
    assert "error[RC201]" in done.stderr and "unsafe: chatter" in done.stderr
    assert "✓ safe: solo" in done.stderr      # each system is checked on its own


def test_roots_and_files_no_system_includes(repo, monkeypatch) -> None:
    monkeypatch.chdir(repo)
    from checker.cli.hooks import repository_files
    files = repository_files(str(repo))
    assert roots_of(["sys/common/messages.arch"], files) == (["sys/robot.arch"], [])
    assert roots_of(["sys/robot.arch", "sys/parts/nodes.arch"], files) == (["sys/robot.arch"], [])
    assert roots_of(["lib/orphan.arch"], files) == ([], ["lib/orphan.arch"])
    (repo / "broken.arch").write_text("component {\n", encoding="utf-8")
    assert roots_of(["broken.arch"], files) == (["broken.arch"], [])


def test_a_file_no_system_includes_is_named_and_passes(repo) -> None:
    done = run(repo, "reconf-check", "--engine", "python", "lib/orphan.arch")
    assert done.returncode == 0
    assert "lib/orphan.arch declares no system" in done.stderr


def test_a_file_that_does_not_parse_is_bad_input(repo) -> None:
    (repo / "broken.arch").write_text("system s\ncomponent {\n", encoding="utf-8")
    done = run(repo, "reconf-check", "--engine", "python", "broken.arch")
    assert done.returncode == 2 and "error[RC001]" in done.stderr


def test_fmt_fixes_in_place_and_fails_when_it_changed_something(repo) -> None:
    messy = repo / "other/solo.arch"
    canonical = CliRunner().invoke(main, ["fmt", "--stdout", str(messy)]).stdout
    messy.write_text(canonical, encoding="utf-8")
    done = run(repo, "reconf-fmt", "other/solo.arch")
    assert done.returncode == 0, done.stderr            # nothing to change
    messy.write_text(canonical.replace("  output out: String", "output    out :String"), encoding="utf-8")
    done = run(repo, "reconf-fmt", "other/solo.arch")
    assert done.returncode == 1
    assert "formatted other/solo.arch" in done.stderr and "commit again" in done.stderr
    assert messy.read_text(encoding="utf-8") == canonical
    done = run(repo, "reconf-fmt", "other/solo.arch")
    assert done.returncode == 0, done.stderr


def test_fmt_on_a_file_that_does_not_parse_changes_nothing(repo) -> None:
    (repo / "broken.arch").write_text("system s\ncomponent {\n", encoding="utf-8")
    done = run(repo, "reconf-fmt", "broken.arch")
    assert done.returncode == 2 and "RC001" in done.stderr
    assert (repo / "broken.arch").read_text(encoding="utf-8") == "system s\ncomponent {\n"
