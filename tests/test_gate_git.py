"""`reconf gate` on git revisions: only the named file, the files it includes (transitively)
and the policy are read from a revision, never the whole tree; findings are reported at the
work tree's paths."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import tracemalloc
from pathlib import Path

import pytest

from checker.gate.revisions import _CatFile, path_to_load, revisions
from tests.support.gatekit import NODES, ROBOT, SPLIT, gate, git, write_tree
from tests.support.sarif import validate_sarif

pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="git is not installed")


BIG = 16 * 1024 * 1024


@pytest.fixture
def repo(tmp_path, monkeypatch) -> Path:
    """sys/robot.arch includes sys/parts/nodes.arch, which includes sys/common/messages.arch; beside
    them, a big unrelated file and an unrelated .arch file. HEAD~1 is safe, HEAD's talker is too slow."""
    r = tmp_path / "repo"
    write_tree(r, {**SPLIT, "other/unrelated.arch": "system other\n"})
    (r / "data").mkdir()
    (r / "data" / "blob.bin").write_bytes(os.urandom(BIG))
    git(r, "init", "-q")
    git(r, "add", ".")
    git(r, "commit", "-q", "-m", "base")
    (r / "sys/parts/nodes.arch").write_text(NODES.replace("RATE", "5 Hz"), encoding="utf-8")
    git(r, "commit", "-q", "-am", "slower")
    monkeypatch.chdir(r)
    return r


def test_only_the_named_file_and_its_includes_are_read(repo, monkeypatch) -> None:
    asked: list[str] = []
    blob = _CatFile.blob

    def spy(self: _CatFile, name: str, limit: int):  # type: ignore[no-untyped-def]
        asked.append(name.split(":", 1)[1])
        return blob(self, name, limit)

    monkeypatch.setattr(_CatFile, "blob", spy)
    commands: list[list[str]] = []
    run = subprocess.run

    def record(args, *a, **k):  # type: ignore[no-untyped-def]
        commands.append(list(args))
        return run(args, *a, **k)

    monkeypatch.setattr(subprocess, "run", record)
    tracemalloc.start()
    try:
        with revisions() as revs:
            path = path_to_load("git:HEAD~1:sys/robot.arch", revs)
            peak = tracemalloc.get_traced_memory()[1]
            root = next(iter(revs.roots.values()))
            written = sorted(str(p.relative_to(root)) for p in Path(root).rglob("*") if p.is_file())
            assert Path(path).read_text(encoding="utf-8") == ROBOT
    finally:
        tracemalloc.stop()
    assert asked == ["sys/robot.arch", "sys/parts/nodes.arch", "sys/common/messages.arch"]
    assert written == ["sys/common/messages.arch", "sys/parts/nodes.arch", "sys/robot.arch"]
    assert not [c for c in commands if "archive" in c]
    assert peak < BIG // 8, peak                      # the big file was not read, not even through a pipe
    assert not os.path.exists(root)                   # the files read are removed afterwards


def test_gate_between_revisions_reports_at_the_work_tree_path(repo) -> None:
    code, out, _ = gate("--base", "git:HEAD~1:sys/robot.arch", "--head", "git:HEAD:sys/robot.arch", fmt="sarif")
    assert code == 1
    results = validate_sarif(out)["runs"][0]["results"]
    rc201 = [r for r in results if r["ruleId"] == "RC201"]
    assert rc201 and rc201[0]["locations"][0]["physicalLocation"]["artifactLocation"]["uri"] == "sys/parts/nodes.arch"
    # the work tree against its own history: the same file name, and the snippet is the work tree's line
    (repo / "sys/parts/nodes.arch").write_text(NODES.replace("RATE", "5 Hz").replace("assume String @ 10 Hz",
                                                                                     "assume String @ 100 ms"),
                                               encoding="utf-8")
    code, _, err = gate("--base", "git:HEAD~1:sys/robot.arch", "--head", "sys/robot.arch", fmt="text")
    assert code == 1
    assert "sys/parts/nodes.arch:14:21: error[RC201]" in err and "14 |     normal { assume String @ 100 ms }" in err


def test_missing_include_and_missing_revision_are_clear(repo) -> None:
    (repo / "sys" / "robot.arch").write_text(ROBOT.replace("parts/nodes.arch", "parts/gone.arch"), encoding="utf-8")
    git(repo, "commit", "-q", "-am", "dangling include")
    code, out, _ = gate("--base", "git:HEAD~1:sys/robot.arch", "--head", "git:HEAD:sys/robot.arch")
    assert code == 2
    (d,) = json.loads(out)["diagnostics"]
    assert d["code"] == "RC008" and d["span"]["file"] == "sys/robot.arch" and d["span"]["line"] == 2
    assert "reconf-rev-" not in d["message"] and "sys/parts/gone.arch" in d["message"]
    code, out, _ = gate("--base", "git:nosuchref:sys/robot.arch", "--head", "sys/robot.arch")
    assert code == 2
    (d,) = json.loads(out)["diagnostics"]
    assert d["code"] == "RC506" and "no revision 'nosuchref'" in d["message"]
    code, out, _ = gate("--base", "git:HEAD:sys/nothing.arch", "--head", "sys/robot.arch")
    assert code == 2 and "there is no sys/nothing.arch at HEAD" in json.loads(out)["diagnostics"][0]["message"]


def test_policy_from_a_revision(repo) -> None:
    """--policy git:REF:PATH: the policy as the base has it, which the change cannot loosen."""
    (repo / "reconf.toml").write_text('never-degrade = ["talk"]\n', encoding="utf-8")
    git(repo, "add", "reconf.toml")
    git(repo, "commit", "-q", "-m", "policy")
    (repo / "reconf.toml").write_text('never-degrade = ["tlak"]\n', encoding="utf-8")   # in the work tree only
    code, out, _ = gate("--base", "git:HEAD~2:sys/robot.arch", "--head", "git:HEAD~2:sys/robot.arch",
                        "--policy", "git:HEAD:reconf.toml")
    assert code == 0, out
    assert json.loads(out)["policy"]["never-degrade"] == ["talk"]
    code, out, _ = gate("--base", "git:HEAD~2:sys/robot.arch", "--head", "git:HEAD~2:sys/robot.arch",
                        "--policy", "reconf.toml")
    assert code == 2
    (d,) = json.loads(out)["diagnostics"]
    assert d["code"] == "RC508" and d["span"]["file"] == "reconf.toml" and "did you mean 'talk'?" in d["notes"]
    git(repo, "commit", "-q", "-am", "misspelt policy")
    code, out, _ = gate("--base", "git:HEAD~3:sys/robot.arch", "--head", "git:HEAD~3:sys/robot.arch",
                        "--policy", "git:HEAD:reconf.toml")
    assert code == 2
    (d,) = json.loads(out)["diagnostics"]
    assert d["span"]["file"] == "reconf.toml" and "at HEAD" in d["message"]


def test_a_file_over_the_limit_is_refused_unread(repo, monkeypatch) -> None:
    import checker.gate.revisions
    from reconf_dsl.diagnostics import DiagnosticError
    monkeypatch.setattr(checker.gate.revisions, "MAX_FILE_BYTES", 1024 * 1024)
    tracemalloc.start()
    try:
        with revisions() as revs, pytest.raises(DiagnosticError) as e:
            path_to_load("git:HEAD:data/blob.bin", revs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    (d,) = e.value.diagnostics
    assert d.code == "RC010" and f"is {BIG} bytes" in d.message
    assert peak < BIG // 8
    # after a refusal, the revision's other files are still read (by a new git process)
    with revisions() as revs:
        with pytest.raises(DiagnosticError):
            path_to_load("git:HEAD:data/blob.bin", revs)
        assert Path(path_to_load("git:HEAD:sys/robot.arch", revs)).read_text(encoding="utf-8") == ROBOT
