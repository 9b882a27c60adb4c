"""A short seeded fault campaign (`bench/bench_faults.py`) in the suite: the chatter talker's
replacement, two runs of each fault kind (in two halves) (a node killed, a node stopped for 3 s, the plan script
interrupted, the plan script killed), each followed by the recovery the run offers and checked
by a probe of its own; and a manager interrupted while it applies a plan."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bench.bench_faults import KINDS, campaign, table
from reconf_ros.tools.livetest import LiveSystem

from .conftest import example


@pytest.mark.parametrize("seed_start", [0, 4])
def test_every_fault_is_recovered_and_every_report_is_true(tmp_path: Path, seed_start: int) -> None:
    """Each half (the first chatter runs from `seed_start`) strikes every fault kind once; the
    halves are two tests so that `make test` can run them beside each other's stream."""
    said: list[str] = []
    runs = campaign(len(KINDS), seed_start, ("chatter",), use_alloy=False, work=tmp_path, say=said.append)
    assert sorted(r.kind for r in runs) == sorted(KINDS), said
    failed = [line for line, r in zip(said, runs) if not r.ok]
    assert failed == [], "\n".join(said) + "\n" + table(runs)


def test_an_interrupted_manager_stops_the_plan_at_the_step_s_end(live: LiveSystem) -> None:
    """SIGTERM to the manager during the create: the step ends, the report is written, the
    client hears exit 130, and the manager ends without a traceback."""
    sock = live.manager()
    manager = next(p for p in live.procs if p.args[2:3] == ["reconf_ros.tools.manager"])
    live.deploy(example("chatter.arch"))
    live.wait_ready()
    script = live.plan_script(["replace", "talker", "-f", example("chatter.arch")])
    client = subprocess.Popen([sys.executable, str(script), "--yes", "--manager", sock, "--log-dir",
                               str(live.dir / "logs"), "--report", str(live.dir / "report.json")],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=live.env, cwd=live.dir)
    live.pids.add(client.pid)
    assert client.stdout is not None
    lines = []
    for line in client.stdout:
        lines.append(line)
        if re.search(r"started talker_v2: pid (\d+)", line):
            live.pids.add(int(re.search(r"pid (\d+)", line).group(1)))  # type: ignore[union-attr]
            manager.send_signal(signal.SIGTERM)
    out = "".join(lines)
    assert client.wait(timeout=60) == 130, out
    assert "INTERRUPTED by SIGTERM after step 1: stopped at the step's end" in out, out
    report = live.report()
    assert report["outcome"] == "interrupted" and report["interrupted_by"] == "SIGTERM"
    assert "talker_v2" in report["observed"]["components"] and "talker_v2" in report["started"]
    assert manager.wait(timeout=30) == 0
    log = (live.dir / "manager.log").read_text()
    assert "Traceback" not in log and "stopping" in log, log
    time.sleep(0.1)
    assert not os.path.exists(sock)
