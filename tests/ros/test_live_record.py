"""A recording of the live chatter system, made by reconf_ros.record, judged by `check --bag`:
the example's model holds on it, and a copy that promises 50 Hz is contradicted with evidence."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from reconf_ros.livetest import LiveSystem

from .conftest import example


def reconf(live: LiveSystem, *args: str) -> subprocess.CompletedProcess[str]:
    exe = os.path.join(os.path.dirname(sys.executable), "reconf")
    return subprocess.run([exe, *args], capture_output=True, text=True, env=live.env, timeout=60)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Path]]:
    """The deployed chatter system, recorded 3 s at once by two recorders (sqlite3 and MCAP)."""
    work = tmp_path_factory.mktemp("record")
    with LiveSystem(work) as live:
        live.watch()
        live.deploy(example("chatter.arch"))
        live.wait_ready()
        bags = {s: work / f"rec-{s}" for s in ("sqlite3", "mcap")}
        procs = {s: live.start([sys.executable, "-m", "reconf_ros.record", str(b), "--topic", "/chatter",
                                "--duration", "3", "--storage", s], f"record-{s}.log") for s, b in bags.items()}
        for s, p in procs.items():
            assert p.wait(timeout=40) == 0, (work / f"record-{s}.log").read_text()
    return work, bags


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_the_example_holds_on_its_recording(recorded: tuple[Path, dict[str, Path]], storage: str) -> None:
    work, bags = recorded
    res = subprocess.run([os.path.join(os.path.dirname(sys.executable), "reconf"), "check", example("chatter.arch"),
                          "--engine", "python", "--bag", str(bags[storage]), "--output-format", "json"],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    rec = json.loads(res.stdout)["recording"]
    assert rec["storage"] == storage and rec["judged"]["topics"] == ["/chatter"]
    assert 20 <= rec["judged"]["messages"] <= 40 and 2.0 <= rec["judged"]["seconds"] <= 3.5
    topic = next(p for p in rec["promises"] if p["who"] == "topic /chatter promises")
    assert 9.0 <= topic["observed"]["hz"] <= 11.5, topic       # the talker's 10 Hz timer, as received
    assert {p["verdict"] for p in rec["promises"]} == {"met"}


def test_a_model_promising_more_is_contradicted(recorded: tuple[Path, dict[str, Path]]) -> None:
    work, bags = recorded
    fast = work / "chatter_50hz.arch"
    fast.write_text(Path(example("chatter.arch")).read_text(encoding="utf-8").replace("@ 10 Hz", "@ 50 Hz"),
                    encoding="utf-8")
    res = subprocess.run([os.path.join(os.path.dirname(sys.executable), "reconf"), "check", str(fast),
                          "--engine", "python", "--bag", str(bags["mcap"]), "--output-format", "json"],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 1, res.stderr
    doc = json.loads(res.stdout)
    diags = [d for d in doc["diagnostics"] if d["code"] == "RC702"]
    guarantee = next(d for d in diags if "talker.talk guarantees" in d["message"])
    assert re.fullmatch(r"/chatter: (9\.\d+|1\d\.?\d*) Hz over the worst 1 s window at t = \d+\.\d s; "
                        r"talker\.talk guarantees 50 Hz \(the topic's rate, all publishers\)", guarantee["message"])
    assert guarantee["span"]["file"] == str(fast) and guarantee["span"]["line"] == 13
    assert {d["span"]["line"] for d in diags} == {13, 33, 36, 41}   # talker (not talker_v2: not deployed), listener, topic
