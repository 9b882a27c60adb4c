"""The environment in a migration: the plan runs in the deployed architecture's
environment, and a target relying on a guarantee only it declares is refused with the
guarantee named (docs/soundness.md, "The environment in a migration")."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from checker.planning import NoSafePlan, plan_migrate
from checker.semantic_model.actions import is_valid
from reconf_dsl.loader import load
from tests.examples_table import path

CHATTER, ROBOT = path("examples", "chatter.arch"), path("examples", "robot.arch")


def test_the_missing_environment_guarantee_is_named() -> None:
    with pytest.raises(NoSafePlan) as err:
        plan_migrate(load([CHATTER]), load([ROBOT]))
    (reason,) = err.value.reasons
    assert reason.startswith("obstacle_detector.detect assumes Image @ 15 Hz, which only robot's environment "
                             "guarantees (environment camera: Image @ 30 Hz, ")
    assert "robot.arch:8); a migration runs in the environment of chatter, which no action changes" in reason
    assert "declare `environment camera: Image @ 30 Hz` in chatter" in reason


def test_declared_in_the_deployed_architecture_it_is_planned(tmp_path: Path) -> None:
    old = tmp_path / "chatter_camera.arch"
    text = Path(CHATTER).read_text(encoding="utf-8")
    old.write_text(text.replace("message String", "environment camera: Image @ 30 Hz\n\nmessage Image = "
                                "sensor_msgs/msg/Image\nmessage String", 1), encoding="utf-8")
    deployed, target = load([str(old)]), load([ROBOT])
    plan = plan_migrate(deployed, target)
    assert all(is_valid(plan.system, s) for s in plan.states)
    assert plan.states[-1].components == frozenset(c.name for c in target.components)


def test_an_environment_the_target_does_not_need_is_no_obstacle() -> None:
    robot = load([ROBOT])
    # robot without its camera, to robot: the camera is needed, and named
    blind = replace(robot, environment=())
    with pytest.raises(NoSafePlan, match="only robot's environment guarantees"):
        plan_migrate(blind, robot)
    # robot to robot without the camera declared: nothing in the target needs what is gone
    assert plan_migrate(robot, robot).steps == []
