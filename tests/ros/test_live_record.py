"""A recording of the live chatter system, made by reconf_ros.tools.record, judged by `check --bag`:
the example's model holds on it, /diagnostics (every reconf node's 1 Hz status) as a slow second
topic starts when /chatter does, a copy that promises 50 Hz is contradicted with evidence, and
the recorder's failures leave nothing behind."""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from checker.reality.bag import STARTED, STOPPED
from reconf_ros.tools.livetest import LiveSystem

from .conftest import example

RECORD = [sys.executable, "-m", "reconf_ros.tools.record"]
TOPICS = ["--topic", "/chatter", "--topic", "/diagnostics"]


def reconf(*args: str) -> subprocess.CompletedProcess[str]:
    exe = os.path.join(os.path.dirname(sys.executable), "reconf")
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=60)


def wait_for_line(log: Path, text: str, timeout: float) -> None:
    end = time.monotonic() + timeout
    while text not in (log.read_text() if log.exists() else ""):
        assert time.monotonic() < end, f"{log.name}: no {text!r} within {timeout} s"
        time.sleep(0.05)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Path], dict[str, int]]:
    """The deployed chatter system, its /chatter and /diagnostics recorded 3 s at once by two
    recorders (sqlite3 and MCAP), beside three recorders that must fail: a topic nobody publishes
    (--wait 1), the same interrupted while it waits, and /chatter where std_msgs cannot be imported."""
    work = tmp_path_factory.mktemp("record")
    shadow = work / "shadow" / "std_msgs"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text("raise ImportError('std_msgs is not installed here')\n")
    codes: dict[str, int] = {}
    with LiveSystem(work) as live:
        live.watch()
        live.deploy(example("chatter.arch"))
        live.wait_ready()
        bags = {s: work / f"rec-{s}" for s in ("sqlite3", "mcap")}
        procs = {s: live.start([*RECORD, str(b), *TOPICS, "--duration", "3", "--storage", s], f"record-{s}.log")
                 for s, b in bags.items()}
        procs["nobody"] = live.start([*RECORD, str(work / "nobody"), "--topic", "/nobody", "--duration", "1",
                                      "--wait", "1"], "record-nobody.log")
        procs["interrupted"] = live.start([*RECORD, str(work / "interrupted"), "--topic", "/nobody", "--duration", "1",
                                           "--wait", "30"], "record-interrupted.log")
        live.env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(shadow.parent), os.environ.get("PYTHONPATH")]))
        procs["no-package"] = live.start([*RECORD, str(work / "no-package"), "--topic", "/chatter", "--duration", "1"],
                                         "record-no-package.log")
        del live.env["PYTHONPATH"]
        wait_for_line(work / "record-interrupted.log", "waiting for the publishers of /nobody", 30)
        os.kill(procs["interrupted"].pid, signal.SIGINT)
        for s, p in procs.items():
            codes[s] = p.wait(timeout=40)
    return work, bags, codes


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_the_example_holds_on_its_recording(recorded: tuple[Path, dict[str, Path], dict[str, int]],
                                            storage: str) -> None:
    work, bags, codes = recorded
    assert codes[storage] == 0, (work / f"record-{storage}.log").read_text()
    res = reconf("check", example("chatter.arch"), "--engine", "python", "--bag", str(bags[storage]),
                 "--output-format", "json")
    assert res.returncode == 0, res.stderr
    rec = json.loads(res.stdout)["recording"]
    assert rec["storage"] == storage and rec["judged"]["topics"] == ["/chatter"] and rec["bounds"] == "recorder"
    assert 20 <= rec["judged"]["messages"] <= 40 and 2.9 <= rec["seconds"] <= 3.5
    topic = next(p for p in rec["promises"] if p["who"] == "topic /chatter promises")
    assert 9.0 <= topic["observed"]["hz"] <= 11.5, topic       # the talker's 10 Hz timer, as received
    assert {p["verdict"] for p in rec["promises"]} == {"met"}


def test_every_topic_starts_at_the_recorder_s_start(recorded: tuple[Path, dict[str, Path], dict[str, int]]) -> None:
    """What arrived before every topic was matched is dropped: both topics' first messages follow
    the written start within their period, and /diagnostics, judged from that start, holds 1 Hz."""
    from rosbags.rosbag2 import Reader
    work, bags, _ = recorded
    with Reader(bags["mcap"]) as r:
        custom = r.storage.metadata.custom or {}
        started, stopped = int(custom[STARTED]), int(custom[STOPPED])
        first: dict[str, int] = {}
        for conn, t, _ in r.messages():
            first.setdefault(conn.topic, t)
    assert 3.0 <= (stopped - started) / 1e9 <= 3.5
    assert 0 <= first["/chatter"] - started <= 0.25e9 and 0 <= first["/diagnostics"] - started <= 1.1e9, first
    slow = work / "chatter_diagnostics.arch"
    slow.write_text(Path(example("chatter.arch")).read_text(encoding="utf-8")
                    + "\nmessage DiagnosticArray = diagnostic_msgs/msg/DiagnosticArray\n"
                      "topic /diagnostics: DiagnosticArray @ 1 Hz { }\n", encoding="utf-8")
    res = reconf("check", str(slow), "--engine", "python", "--bag", str(bags["mcap"]), "--output-format", "json")
    assert res.returncode == 0, res.stderr
    rec = json.loads(res.stdout)["recording"]
    assert rec["judged"]["topics"] == ["/chatter", "/diagnostics"]
    diag = next(p for p in rec["promises"] if p["who"] == "topic /diagnostics promises")
    assert diag["verdict"] == "met" and 0.9 <= diag["observed"]["hz"] <= 4, diag   # talker's and listener's 1 Hz


def test_a_model_promising_more_is_contradicted(recorded: tuple[Path, dict[str, Path], dict[str, int]]) -> None:
    work, bags, _ = recorded
    fast = work / "chatter_50hz.arch"
    fast.write_text(Path(example("chatter.arch")).read_text(encoding="utf-8").replace("@ 10 Hz", "@ 50 Hz"),
                    encoding="utf-8")
    res = reconf("check", str(fast), "--engine", "python", "--bag", str(bags["mcap"]), "--output-format", "json")
    assert res.returncode == 1, res.stderr
    doc = json.loads(res.stdout)
    diags = [d for d in doc["diagnostics"] if d["code"] == "RC702"]
    guarantee = next(d for d in diags if "talker.talk guarantees" in d["message"])
    assert re.fullmatch(r"/chatter: (9\.\d+|1\d\.?\d*) Hz over the worst 1 s window at t = \d+\.\d s; "
                        r"talker\.talk guarantees 50 Hz \(the topic's rate, all publishers\)", guarantee["message"])
    assert guarantee["span"]["file"] == str(fast) and guarantee["span"]["line"] == 13
    assert {d["span"]["line"] for d in diags} == {13, 33, 36, 41}   # talker (not talker_v2: not deployed), listener, topic


@pytest.mark.parametrize(("case", "code", "said"), [
    ("nobody", 2, "no publisher of /nobody within 1 s: nothing recorded"),
    ("interrupted", 130, "interrupted before recording started: nothing recorded"),
    ("no-package", 2, "cannot record /chatter: the type std_msgs/msg/String has no Python message class here "
                      "(ImportError: std_msgs is not installed here): install its package"),
])
def test_a_failed_recording_leaves_nothing(recorded: tuple[Path, dict[str, Path], dict[str, int]], case: str,
                                           code: int, said: str) -> None:
    work, _, codes = recorded
    log = (work / f"record-{case}.log").read_text()
    assert codes[case] == code and said in log and "Traceback" not in log, log
    assert not (work / case).exists() and not list(work.glob(f".{case}.partial-*"))
