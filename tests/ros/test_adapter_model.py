"""The adapter's model half (no node started): a component with a `node` block is its own model
(`reconf-node --describe`, its `reconf.model`), the command line it starts remaps the node and
its ports to private names, and a plan document carries the block (docs/adapter.md)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from codegen.ros2 import model_data, system_from_model_data
from reconf_dsl.ir import Component as IrComponent
from reconf_dsl.loader import load
from reconf_dsl.parser import parse_text
from reconf_ros import components_to_arch

from .conftest import example

pytest.importorskip("rclpy")

from reconf_ros.nodes.adapter import exit_text, from_architecture  # noqa: E402
from reconf_ros.nodes.wrapped import Wrapped, ros_namespace  # noqa: E402

ADAPTED = [(arch, c.name) for arch in ("unmodified.arch", "chatter_unmodified.arch")
           for c in load([example(arch)]).components + load([example(arch)]).versions if c.node is not None]


@pytest.mark.parametrize("arch, name", ADAPTED)
def test_an_adapted_component_prints_itself_as_the_architecture_has_it(arch: str, name: str) -> None:
    system = load([example(arch)])
    comp = from_architecture(system, name)
    items = parse_text(components_to_arch([comp], "again"), "again.arch").items
    back = next(c for c in items if isinstance(c, IrComponent) and c.name == name)
    ours = system.component(name)
    assert back is not None and ours is not None
    assert (back.node, back.run, back.ports, back.functionalities) == (ours.node, ours.run, ours.ports,
                                                                        ours.functionalities)


def test_reconf_node_describes_an_adapted_component() -> None:
    res = subprocess.run([str(Path(sys.executable).with_name("reconf-node")), "--arch", example("unmodified.arch"),
                          "lc_talker", "--describe"], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert "  node lc_talker lifecycle {\n    out = /chatter\n    talk degraded: deactivate\n  }\n" in res.stdout


def test_the_node_block_goes_through_a_plan_document() -> None:
    system = load([example("unmodified.arch")])
    again = system_from_model_data(model_data(system))
    assert [c.node for c in again.components + again.versions] == [c.node for c in system.components + system.versions]


def test_the_wrapped_command_remaps_the_node_and_its_ports() -> None:
    system = load([example("unmodified.arch")])
    listener = system.component("listener")
    assert listener is not None and listener.node is not None and listener.run is not None
    w = Wrapped(listener.run + " --ros-args -p x:=1", listener.node, "listener", "/robot")
    argv = w.command()
    assert argv[0] == shutil_which("python3") and argv[1:4] == ["-m", "reconf_ros.demo.unmodified", "listener"]
    rules = [argv[i + 1] for i, a in enumerate(argv) if a == "-r"]
    assert rules == ["listener:__node:=_wrapped_listener", "_wrapped_listener:__ns:=/robot",
                     "_wrapped_listener:/chatter:=/robot/_wrapped_listener/in",
                     "_wrapped_listener:/heard:=/robot/_wrapped_listener/out"]
    assert argv.count("--ros-args") == 1 and argv[-2:] == ["-p", "x:=1"]      # its own arguments kept
    assert ros_namespace(["x", "--ros-args", "-r", "__ns:=/robot/"]) == "/robot"
    assert (exit_text(-9), exit_text(3)) == ("signal SIGKILL", "status 3")


def shutil_which(name: str) -> str:
    import shutil
    found = shutil.which(name) or shutil.which(name, path=os.path.dirname(sys.executable))
    assert found is not None
    return found


def test_a_node_module_next_to_the_architecture_is_found(tmp_path: Path) -> None:
    """`reconf-node mynodes:sensor` run where the module is, without PYTHONPATH (as `python -m`)."""
    (tmp_path / "mynodes.py").write_text(
        "from reconf_ros import Component\n\n"
        "def sensor():\n    c = Component('sensor')\n    out = c.create_output('out', 'std_msgs/msg/String')\n"
        "    f = c.create_functionality('sense', outputs=[out])\n    f.set_normal_mode(None, rate=5, outputs=[out])\n"
        "    f.set_degraded_mode()\n    return c\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    res = subprocess.run([str(Path(sys.executable).with_name("reconf-node")), "mynodes:sensor", "--describe"],
                         capture_output=True, text=True, cwd=tmp_path, env=env, timeout=60)
    assert res.returncode == 0, res.stderr
    assert "component sensor {" in res.stdout and "run \"reconf-node mynodes:sensor\"" in res.stdout


def test_an_undeclared_parameter_is_not_a_value() -> None:
    """rclpy answers get_parameters naming an undeclared parameter with no value at all, rclcpp
    with NOT_SET: either way, a node without the control interface, said in one line."""
    from types import SimpleNamespace

    from rcl_interfaces.msg import ParameterType, ParameterValue

    from reconf_ros.executor.runtime import NoControlInterface, Runtime, StepFailed
    rt = Runtime.__new__(Runtime)
    rt.ParameterType = ParameterType
    names = ["reconf.mode.talk", "reconf.port.out"]
    for values in ([], [ParameterValue(type=ParameterType.PARAMETER_NOT_SET)] * 2):
        with pytest.raises(NoControlInterface, match="does not implement the control interface: no value for "
                                                     "reconf.mode.talk") as e:
            rt.values("/lc_talker", names, SimpleNamespace(values=values))
        assert isinstance(e.value, StepFailed) and "\n" not in str(e.value)
    ok = [ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="normal"),
          ParameterValue(type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=["/chatter"])]
    assert rt.values("/talker", names, SimpleNamespace(values=ok)) == {"reconf.mode.talk": "normal",
                                                                        "reconf.port.out": ["/chatter"]}


def test_two_readers_of_one_input_take_each_message_once() -> None:
    from reconf_ros.nodes.monitor import Monitor
    system = load([example("chatter.arch")])
    from reconf_ros.nodes.generic import from_architecture as model_driven
    mon = Monitor(model_driven(system, "listener"))
    gid = b"talker-gid"
    assert not mon.duplicate("in", gid, 1)
    mon.on_message("in", 1.0, gid, 1, "talker")
    mon.on_message("in", 1.1, gid, 2, "talker")
    assert mon.duplicate("in", gid, 2) and mon.duplicate("in", gid, 1) and not mon.duplicate("in", gid, 3)
    assert not mon.duplicate("in", b"other", 2) and not mon.duplicate("in", gid, None)
