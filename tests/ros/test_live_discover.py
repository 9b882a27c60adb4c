"""`reconf discover` and `reconf drift` on a running system: the chatter example with its real
nodes (one process each) and, later, a plain rclpy node. One live system for the module; the
tests run in order, each changing it further."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from typing import Any, Iterator

import pytest

from reconf_dsl.loader import load
from reconf_ros.tools.livetest import LiveSystem

from .conftest import example

CHATTER = example("chatter.arch")
# the operator's changes, made through the control interface with the executor's own client
CHANGE = """
from reconf_ros.executor.runtime import Runtime
rt = Runtime("drift_test", "", 5.0)
rt.wait(lambda: "/listener" in rt.nodes(), 15)
rt.set("/listener", "reconf.mode.listen", "degraded")
rt.set("/listener", "reconf.port.in", ["/elsewhere"])
rt.close()
"""
# an operator's node asking the talker for its parameters (a client of a standard service, no
# topic of the application): neither drift nor discover takes it for a part of the system
OPERATOR = """
import rclpy
from rcl_interfaces.srv import GetParameters
rclpy.init()
node = rclpy.create_node("operator")
node.create_client(GetParameters, "/talker/get_parameters")
rclpy.spin(node)
"""


@pytest.fixture(scope="module")
def system(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[LiveSystem, list[Any]]]:
    live = LiveSystem(tmp_path_factory.mktemp("discover"))
    try:
        live.watch()
        procs = live.deploy(CHATTER, group=False)
        live.start([sys.executable, "-c", OPERATOR], "operator.log")
        live.wait_ready(timeout=30)
        yield live, procs
    finally:
        live.stop()


def reconf(live: LiveSystem, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "checker", *args], capture_output=True, text=True, env=live.env,
                          cwd=live.dir, timeout=60)


def test_drift_on_the_system_as_deployed_is_none(system: tuple[LiveSystem, list[Any]]) -> None:
    live, _ = system
    res = reconf(live, "drift", CHATTER, "--output-format", "json")
    assert res.returncode == 0, res.stdout + res.stderr
    doc = json.loads(res.stdout)
    assert doc["verdict"] == "in sync" and doc["diagnostics"] == [] and doc["settled"]
    assert {"/talker", "/listener", "/operator"} <= set(doc["nodes"])     # the operator read, not extra
    assert not any(n.rsplit("/", 1)[1].startswith("_") for n in doc["nodes"])   # reconf's own: hidden
    # the rule: one announcement period of the profile (0.25 s) and the margin, and the graph quiet
    from reconf_ros.executor.runtime import DISCOVERY_MARGIN, ENDPOINTS_QUIET, announcement_period
    least = max(announcement_period(live.env) + DISCOVERY_MARGIN, ENDPOINTS_QUIET)
    assert doc["seconds"]["settle"] >= least and "s waiting for discovery" in res.stderr, res.stderr


def test_discover_writes_the_deployed_part_and_a_plain_node_with_placeholders(
        system: tuple[LiveSystem, list[Any]]) -> None:
    live, _ = system
    live.start([sys.executable, "-m", "reconf_ros.demo.plain"], "plain.log")
    out = live.dir / "found.arch"
    res = reconf(live, "discover", "--system", "chatter", "-o", str(out))
    assert res.returncode == 0, res.stderr
    check = reconf(live, "check", "--engine", "python", str(out))
    assert check.returncode == 0, check.stderr
    found, model = load([str(out)]), load([CHATTER])
    for comp in model.components:
        assert found.component(comp.name) == comp      # ports, functionalities, predicates, run, host
    chatter = found.connector("/chatter")
    assert chatter is not None and chatter.guarantee == model.connectors[0].guarantee
    assert [str(r) for r in chatter.publishers] == ["talker.out"]
    assert [str(r) for r in chatter.subscribers] == ["counter.chatter", "listener.in"]
    counter = found.component("counter")
    assert counter is not None
    assert [(p.name, p.kind, p.message, p.assumption) for p in counter.ports] == [
        ("heard", "output", "Int32", None), ("chatter", "input", "String", counter.ports[1].assumption)]
    assert counter.ports[1].assumption is not None and counter.ports[1].assumption.rate is None
    text = out.read_text()
    assert found.component("operator") is None and "get_parameters" not in text
    assert "// placeholder: node /counter has no reconf.model" in text
    assert res.stderr.count("warning[RC601]") == text.count("// placeholder:") == 2, res.stderr


def test_drift_after_changes_on_the_live_system(system: tuple[LiveSystem, list[Any]]) -> None:
    live, procs = system
    change = subprocess.run([sys.executable, "-c", CHANGE], env=live.env, capture_output=True, text=True, timeout=60)
    assert change.returncode == 0, change.stderr
    talker = procs[0]
    assert talker.args[1].endswith(":talker")
    os.kill(talker.pid, signal.SIGTERM)
    talker.wait(timeout=10)
    res = reconf(live, "drift", CHATTER, "--output-format", "sarif")
    assert res.returncode == 1, res.stdout + res.stderr
    results = json.loads(res.stdout)["runs"][0]["results"]
    found = sorted((r["ruleId"], r["locations"][0]["physicalLocation"]["region"]["startLine"]) for r in results)
    # talker gone (its declaration), the plain node extra (the system line), listener.in moved
    # (its role on /chatter), listen degraded (the functionality)
    assert found == [("RC611", 7), ("RC612", 3), ("RC613", 42), ("RC615", 35)], res.stderr
    listener = live.settle_status(["listener"])["/listener"]["values"]      # as the node itself says
    assert (listener["mode.listen"], listener["port.in"]) == ("degraded", "/elsewhere")
