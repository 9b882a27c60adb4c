"""Live tests: real node processes over Fast DDS on loopback, each test in a domain of its own;
every process a test starts (or a plan script it runs starts) is ended by its PID."""
from __future__ import annotations

from pathlib import Path
from typing import Iterator

import pytest

from reconf_ros.tools.livetest import LiveSystem, ros_available

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
