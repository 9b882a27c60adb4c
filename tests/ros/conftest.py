"""Live tests: real node processes over Fast DDS on loopback, each test in a domain of its own;
every process a test starts (or a plan script it runs starts) is ended by its PID."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import pytest

from reconf_ros.tools.livetest import LiveSystem, ros_available
from reconf_ros.tools.netlab import lab_available

ROOT = Path(__file__).resolve().parents[2]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if "tests/ros/test_live" in str(item.fspath).replace("\\", "/"):
            item.add_marker(pytest.mark.ros)
            if not ros_available():
                item.add_marker(pytest.mark.skip(reason="rclpy is not installed (pip install 'reconf[ros]')"))


@pytest.fixture
def live(tmp_path: Path) -> Iterator[LiveSystem]:
    system = LiveSystem(tmp_path)
    try:
        system.watch()
        yield system
    finally:
        system.stop()


def example(name: str) -> str:
    return str(ROOT / "examples" / name)


def run_script(live: LiveSystem, script: str, timeout: float) -> dict[str, Any]:
    """Run a Python `script` in `live`'s domain (its process ended by PID with the system) and
    return what it printed last, as JSON; a failed script fails the test with its stderr."""
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=live.env)
    live.pids.add(proc.pid)
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err[-2000:]
    return dict(json.loads(out.strip().splitlines()[-1]))


@pytest.fixture
def on_hosts(tmp_path: Path) -> Iterator[Callable[..., LiveSystem]]:
    """Make a live system on a lab of hosts (`on_hosts(["robot", "station"], home="station")`):
    one network namespace per host, each process on its host, the watcher on `home`; the lab
    and every process on it removed at the end, even when the test fails. Skips where labs
    cannot be made (not root, no iproute2)."""
    made: list[LiveSystem] = []

    def make(hosts: Sequence[str], home: str = "") -> LiveSystem:
        why = lab_available()
        if why:
            pytest.skip(f"a lab of hosts cannot be made here: {why}")
        system = LiveSystem(tmp_path / f"lab{len(made)}", hosts=hosts, home=home)
        made.append(system)
        system.watch()
        return system
    try:
        yield make
    finally:
        for system in made:
            system.stop()
