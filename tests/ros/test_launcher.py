"""The manager's launcher (docs/executor.md#launcher): it forks `reconf-node` with its own log,
working directory and environment additions, reports the exit status, and parses an
architecture again when the file changes. `--describe` needs no ROS graph, so no domain."""
from __future__ import annotations

import os
import select
import sys
from pathlib import Path
from typing import Iterator

import pytest

pytest.importorskip("rclpy")

from reconf_ros.executor.launcher import Launcher, launchable  # noqa: E402
from reconf_ros.nodes.api import Component  # noqa: E402

from .conftest import ROOT, example  # noqa: E402

EXE = os.path.join(os.path.dirname(sys.executable), "reconf-node")


def named() -> Component:
    """A factory for the test: a component named by the environment the launcher gave."""
    return Component(os.environ.get("RECONF_TEST_NAME", "unnamed"))


@pytest.fixture
def launcher() -> Iterator[Launcher]:
    la = Launcher()
    yield la
    la.close()
    assert la.proc.returncode is not None


def test_only_this_environments_reconf_node(launcher: Launcher) -> None:
    assert launchable([EXE, "x"])
    assert not launchable(["/usr/bin/reconf-node", "x"]) or os.path.dirname(sys.executable) == "/usr/bin"
    assert not launchable([os.path.join(os.path.dirname(sys.executable), "python"), "-c", "pass"])
    assert launcher.can_start([EXE, "x"])


def test_a_forked_node_has_its_log_directory_environment_and_status(launcher: Launcher, tmp_path: Path) -> None:
    log = tmp_path / "named.log"
    p = launcher.start([EXE, "tests.ros.test_launcher:named", "--describe"], str(log), cwd=str(ROOT),
                       env={"RECONF_TEST_NAME": "from_env", "PYTHONPATH": str(ROOT)})
    assert p.wait(timeout=30) == 0, log.read_text()
    assert "component from_env" in log.read_text()
    bad = launcher.start([EXE, "--arch", example("chatter.arch"), "nosuch", "--describe"], str(tmp_path / "bad.log"))
    assert bad.wait(timeout=30) == 2
    assert "nosuch" in (tmp_path / "bad.log").read_text()


def loaded() -> Component:
    """A factory for the test: says which interfaces' type support its process had loaded, and
    whether it found the launcher's objects frozen (out of reach of its collections)."""
    import gc

    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import Float64
    from std_srvs.srv import Trigger
    print({t.__name__: t.__class__._TYPE_SUPPORT is not None for t in (DiagnosticArray, Float64, Trigger)})
    print(f"frozen: {gc.get_freeze_count() > 0}")
    return Component("loaded")


def test_a_forked_node_finds_the_type_support_of_every_node_s_and_its_architecture_s_messages_loaded(
        launcher: Launcher, tmp_path: Path) -> None:
    import importlib

    from reconf_ros.tools.launcher import NODE_INTERFACES
    from reconf_ros.tools.runner import load_cached
    chain = example("chain5.arch")
    for name in NODE_INTERFACES:        # each names an interface this environment has (none is skipped)
        package, kind, short = name.split("/")
        assert hasattr(importlib.import_module(f"{package}.{kind}"), short), name
    assert {m.ros_type for m in load_cached(chain).messages} == {"std_msgs/msg/Float64"}
    log = tmp_path / "loaded.log"
    p = launcher.start([EXE, "tests.ros.test_launcher:loaded", "--deployed", chain, "--describe"], str(log),
                       cwd=str(ROOT), env={"PYTHONPATH": str(ROOT)})
    assert p.wait(timeout=30) == 0, log.read_text()
    # every node's interfaces and the architecture's messages: loaded before the fork; not others
    assert "{'DiagnosticArray': True, 'Float64': True, 'Trigger': False}" in log.read_text()
    assert "frozen: True" in log.read_text()


def test_an_architecture_is_parsed_again_when_it_changes(launcher: Launcher, tmp_path: Path) -> None:
    arch = tmp_path / "sys.arch"
    arch.write_text(Path(example("chatter.arch")).read_text())
    launcher.warm([EXE, "--arch", str(arch), "talker"])
    first = launcher.start([EXE, "--arch", str(arch), "talker", "--describe"], str(tmp_path / "1.log"))
    assert first.wait(timeout=30) == 0
    arch.write_text(arch.read_text() + "\ncomponent extra {\n  output o: String\n}\n")
    second = launcher.start([EXE, "--arch", str(arch), "extra", "--describe"], str(tmp_path / "2.log"))
    assert second.wait(timeout=30) == 0, (tmp_path / "2.log").read_text()
    assert "component extra" in (tmp_path / "2.log").read_text()


def test_a_client_gone_with_answers_unread_ends_it_quietly(capfd: pytest.CaptureFixture[str]) -> None:
    """A plan script refused before its first step closes its launcher with the answer to a
    warm request unread: the launcher ends with status 0 and no traceback."""
    la = Launcher()
    la.warm([EXE, "--arch", example("chatter.arch"), "talker"])
    assert select.select([la.sock], [], [], 30)[0]      # the answer has arrived, unread
    la.close()
    assert la.proc.returncode == 0
    assert "Traceback" not in capfd.readouterr().err
