"""Held node processes (docs/executor.md#held): the launcher forks a node ahead of its create; the
child initialises ROS and makes no node until released. Released, it makes its node; cancelled,
or with its launcher gone, it exits having made none."""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any, Iterator

import pytest

from reconf_ros.executor.launcher import Launched, Launcher
from reconf_ros.tools.livetest import LiveSystem

from .conftest import example

EXE = os.path.join(os.path.dirname(sys.executable), "reconf-node")


@pytest.fixture
def launcher(live: LiveSystem) -> Iterator[Launcher]:
    la = Launcher()
    yield la
    la.close()


def _held(live: LiveSystem, la: Launcher, name: str, named: bool = True) -> Launched:
    """A held talker: its node named `name` by its command, or (not `named`) by its release."""
    p = la.start([EXE, "--arch", example("chatter.arch"), "talker", *(["--node", name] if named else [])],
                 str(live.dir / f"{name}.log"), env=dict(live.env), hold=True)
    live.pids.add(p.pid)
    return p


def _status(live: LiveSystem, name: str) -> dict[str, Any]:
    return dict(live.statuses().get(f"/{name}", {}).get("values", {}))


def _gone(pid: int) -> bool:
    """No process `pid`, or a zombie (its parent, the launcher, gone before reaping it)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except (FileNotFoundError, ProcessLookupError):
        return True


def test_a_held_process_makes_its_node_only_once_released_under_the_name_given(
        live: LiveSystem, launcher: Launcher) -> None:
    p = _held(live, launcher, "held_talker", named=False)
    # a node publishes its status at once and every second after: 2.5 s without one, and none made
    assert not live.wait(lambda st: bool(st), 2.5), live.statuses()
    assert p.poll() is None, (live.dir / "held_talker.log").read_text()
    t0 = time.monotonic()
    launcher.release(p.pid, {"node": "held_talker"})       # as a new version's create names it
    assert live.wait(lambda st: _status(live, "held_talker").get("pid") == str(p.pid), 10.0), live.statuses()
    assert _status(live, "held_talker").get("component") == "talker"
    assert time.monotonic() - t0 < 10.0
    with pytest.raises(OSError, match="not a held child"):
        launcher.release(p.pid)         # released once, and not held any more


def test_a_cancelled_or_orphaned_held_process_exits_having_made_no_node(live: LiveSystem, launcher: Launcher) -> None:
    cancelled = _held(live, launcher, "cancelled_talker")
    assert not live.wait(lambda st: False, 1.0)         # it has initialised ROS by now, or is doing so
    launcher.cancel(cancelled.pid)
    assert cancelled.wait(timeout=10.0) == 0, (live.dir / "cancelled_talker.log").read_text()
    other = Launcher()
    orphan = _held(live, other, "orphan_talker")
    other.close()                                       # its launcher gone, the held process ends too
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and not _gone(orphan.pid):
        time.sleep(0.05)
    assert _gone(orphan.pid), (live.dir / "orphan_talker.log").read_text()
    assert not any(n in live.statuses() for n in ("/cancelled_talker", "/orphan_talker")), live.statuses()
