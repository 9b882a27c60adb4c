"""Plans carried out on live systems: the model's safety observed on the wire.

Each test deploys an example with its real nodes, plans a change, runs the plan script as a
user would, and asserts what the running system showed: the plan's final state observed by the
executor, no monitor seeing a normal mode's assumption violated, and no message lost by the
new publishers."""
from __future__ import annotations

from typing import Any

import pytest

from reconf_ros.livetest import LiveSystem

from .conftest import example


def source(statuses: dict[str, Any], comp: str, port: str, publisher: str) -> tuple[int, int, int]:
    """(received, lost, missed at its start) of `publisher` as `comp.port` saw it."""
    v = statuses[f"/{comp}"]["values"].get(f"in.{port}.from.{publisher}", "0/0/0")
    received, lost, head = (int(x) for x in v.split("/"))
    return received, lost, head


def applied(live: LiveSystem, res: Any) -> dict[str, Any]:
    assert res.returncode == 0, res.stdout + res.stderr
    assert "no monitor saw a normal mode's assumption violated" in res.stdout
    report = live.report()
    assert report["outcome"] == "done"
    statuses = live.settle_status(report["observed"]["components"] if report.get("observed") else ())
    assert live.violations(statuses) == {}, statuses
    return statuses


@pytest.mark.parametrize("strategy", ["default", "paper"])
def test_replace_talker(live: LiveSystem, strategy: str) -> None:
    arch = example("chatter.arch")
    live.deploy(arch)
    live.wait_ready(["talker", "listener"])
    script = live.plan_script(["replace", "talker", "-f", arch, "--strategy", strategy])
    res = live.run_plan(script)
    statuses = applied(live, res)
    received, lost, head = source(statuses, "listener", "in", "talker_v2")
    assert received > 0 and lost == 0 and head == 0, statuses["/listener"]["values"]
    assert statuses["/talker_v2"]["values"]["mode.talk"] == "normal"
    assert statuses["/talker"]["values"]["lifecycle"] == "inactive"
    gap = float(statuses["/listener"]["values"]["in.in.max_gap_s"])
    assert gap <= 0.15, f"largest gap of the listener while normal: {gap} s"


def test_remove_obstacle_detector(live: LiveSystem) -> None:
    arch = example("robot.arch")
    live.deploy(arch)
    live.wait_ready(["obstacle_detector", "motor_controller", "base_driver"])
    script = live.plan_script(["remove", "obstacle_detector", "-f", arch])
    statuses = applied(live, live.run_plan(script))
    mc = statuses["/motor_controller"]["values"]
    assert mc["mode.control"] == "degraded" and mc["port.in"] == "/obstacles"   # left degraded: nothing publishes
    assert statuses["/base_driver"]["values"]["mode.drive"] == "normal"


def test_replace_one_of_two_redundant_publishers(live: LiveSystem) -> None:
    arch = example("redundant.arch")
    live.deploy(arch)
    live.wait_ready(["lidar_front", "lidar_rear", "mapper"])
    script = live.plan_script(["replace", "lidar_rear", "-f", arch])
    statuses = applied(live, live.run_plan(script))
    assert statuses["/mapper"]["values"]["mode.map"] == "normal"
    received, lost, head = source(statuses, "mapper", "scan", "lidar_rear_v2")
    assert received > 0 and lost == 0 and head == 0


def test_replace_the_head_of_the_chain(live: LiveSystem) -> None:
    arch = example("chain5.arch")
    live.deploy(arch)
    live.wait_ready([f"stage{i}" for i in range(5)])
    script = live.plan_script(["replace", "stage0", "-f", arch])
    statuses = applied(live, live.run_plan(script))
    assert all(statuses[f"/stage{i}"]["values"]["mode.step"] == "normal" for i in range(1, 5))
    assert statuses["/stage0_v2"]["values"]["mode.step"] == "normal"


def test_migration(live: LiveSystem) -> None:
    arch = example("chatter.arch")
    live.deploy(arch)
    live.wait_ready(["talker", "listener"])
    script = live.plan_script(["migrate", arch, example("chatter_migrated.arch")])
    statuses = applied(live, live.run_plan(script))
    for comp in ("listener", "logger"):
        received, lost, head = source(statuses, comp, "in", "talker_fast")
        assert received > 0 and lost == 0 and head == 0, (comp, statuses[f"/{comp}"]["values"])
