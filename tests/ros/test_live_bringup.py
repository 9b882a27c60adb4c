"""`reconf up` and `reconf down` on a live graph: the bundled example started from nothing by its
verified plan and stopped again, what the nodes reported observed at each end."""
from __future__ import annotations

import os
import subprocess
import sys
import time

from reconf_ros.livetest import LiveSystem

from .conftest import example

RECONF = os.path.join(os.path.dirname(sys.executable), "reconf")


def reconf(live: LiveSystem, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([RECONF, *args], capture_output=True, text=True, env=live.env, cwd=live.dir,
                          timeout=120)


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_up_then_down(live: LiveSystem) -> None:
    # Alloy's verdict on this plan is tested without ROS (tests/planning/test_bringup.py)
    up = reconf(live, "up", example("chatter.arch"), "--yes", "--no-alloy", "--log-dir", "logs", "--report", "up.json")
    pids = {c: int(info["pid"]) for c, info in live.report("up.json").get("started", {}).items()}
    live.pids.update(pids.values())              # ended by the fixture if anything below fails
    assert up.returncode == 0, up.stdout + up.stderr
    assert "reconf will bring chatter up in 6 steps" in up.stderr, up.stderr
    assert sorted(pids) == ["listener", "talker"]
    report = live.report("up.json")
    assert report["outcome"] == "done"
    assert report["observed"] == {"components": ["listener", "talker"], "degraded": [],
                                  "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"]]}
    statuses = live.settle_status(["talker", "listener"])
    assert live.violations(statuses) == {}, statuses
    listener = statuses["/listener"]["values"]
    assert listener["mode.listen"] == "normal" and listener["port.in"] == "/chatter"
    assert int(listener["in.in.received"]) > 0

    down = reconf(live, "down", example("chatter.arch"), "--yes", "--no-alloy", "--report", "down.json")
    assert down.returncode == 0, down.stdout + down.stderr
    assert live.report("down.json")["observed"] == {"components": [], "degraded": [], "roles": []}
    end = time.monotonic() + 10
    while any(alive(p) for p in pids.values()) and time.monotonic() < end:
        time.sleep(0.1)
    assert not any(alive(p) for p in pids.values()), "a node did not exit once finalized"
    assert live.watched_violations() == []
