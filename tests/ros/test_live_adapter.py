"""Nodes reconf does not build, driven live through their adapters (docs/adapter.md): plain and
lifecycle rclpy nodes of reconf_ros/demo/unmodified.py, started by their run lines, never
imported. Each test runs real processes in a ROS domain of its own and asserts what the wire
showed: the plan's outcome observed, no monitor seeing a normal mode's assumption violated, and
no message lost by a new publisher."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from reconf_ros.tools.livetest import LiveSystem, alive

from .conftest import example
from .test_live_plans import applied, source

UNMODIFIED = example("unmodified.arch")


def node_pid(statuses: dict[str, Any], comp: str) -> int:
    """The pid of the process of the node `comp`'s adapter drives."""
    return int(statuses[f"/{comp}"]["values"]["node.pid"])


def up(live: LiveSystem, arch: str = UNMODIFIED) -> dict[str, Any]:
    live.deploy(arch)
    live.wait_ready(timeout=40)
    return live.settle_status(live.deployed)


@pytest.mark.parametrize("strategy", ["default", "paper"])
def test_replace_a_plain_talker_by_a_lifecycle_talker(live: LiveSystem, strategy: str) -> None:
    before = up(live)
    plain = node_pid(before, "talker")
    statuses = applied(live, live.run_plan(live.plan_script(["replace", "talker", "-f", UNMODIFIED,
                                                             "--strategy", strategy])))
    received, lost, head = source(statuses, "listener", "in", "lc_talker")
    assert received > 0 and lost == 0 and head == 0, statuses["/listener"]["values"]
    lc = statuses["/lc_talker"]["values"]
    assert (lc["mode.talk"], lc["node.lifecycle"], lc["node.process"]) == ("normal", "active", "running"), lc
    assert int(lc["out.out.published"]) > 0 and lc["out.out.held"] == "0", lc
    assert not alive(plain), "the plain talker's process outlived its removal"
    listener = statuses["/listener"]["values"]
    assert listener["mode.count"] == "normal" and int(listener["out.out.from_node"]) > 0, listener
    gap = float(listener["in.in.max_gap_s"])
    assert gap <= 0.15, f"largest gap of the listener while normal: {gap} s"


def test_remove_a_plain_node_whose_subscriber_degrades(live: LiveSystem) -> None:
    """The listener degrades: its adapter sets the node's parameter (it stops publishing) and
    holds its output back; the talker's process ends with its removal."""
    before = up(live)
    talker = node_pid(before, "talker")
    statuses = applied(live, live.run_plan(live.plan_script(["remove", "talker", "-f", UNMODIFIED])))
    listener = statuses["/listener"]["values"]
    assert listener["mode.count"] == "degraded" and listener["port.out"] == "/heard", listener
    counted = int(listener["out.out.from_node"])
    time.sleep(1.5)                               # the node publishes every 0.5 s while `report` is true
    later = live.settle_status(["listener"])["/listener"]["values"]
    assert int(later["out.out.from_node"]) == counted, "the node went on publishing: its parameter was not set"
    assert not alive(talker)
    assert live.violations() == {}


def test_a_migration_mixing_reconf_nodes_and_unmodified_ones(live: LiveSystem) -> None:
    live.deploy(example("chatter.arch"))
    live.wait_ready()
    script = live.plan_script(["migrate", example("chatter.arch"), example("chatter_unmodified.arch")])
    statuses = applied(live, live.run_plan(script))
    new = next(n for n, s in statuses.items() if s["values"].get("node", "").endswith("_wrapped_talker_2"))
    for comp in ("listener", "counter"):
        received, lost, head = source(statuses, comp, "in", new.lstrip("/"))
        assert received > 0 and lost == 0 and head == 0, (comp, statuses[f"/{comp}"]["values"])
    assert statuses["/counter"]["values"]["mode.count"] == "normal"
    assert statuses[new]["values"]["node.lifecycle"] == "active"


def reconf(live: LiveSystem, *args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(Path(sys.executable).with_name("reconf")), *args], capture_output=True, text=True,
                          env=live.env, cwd=live.dir, timeout=timeout)


def test_up_discover_check_drift_down_of_unmodified_nodes(live: LiveSystem) -> None:
    """`reconf up` of a system made only of nodes reconf does not build; discover writes them
    back with their `node` blocks, check accepts it, drift finds it in sync; `reconf down` takes
    it apart and leaves no process behind."""
    res = reconf(live, "up", UNMODIFIED, "--yes", "--log-dir", str(live.dir / "logs"), "--report", "up.json")
    assert res.returncode == 0, res.stdout + res.stderr
    statuses = live.settle_status(["talker", "listener"])
    pids = [node_pid(statuses, c) for c in ("talker", "listener")] + \
        [int(s["pid"]) for s in json.loads((live.dir / "up.json").read_text())["started"].values()]
    live.pids.update(pids)
    assert live.violations(statuses) == {}
    found = live.dir / "found.arch"
    res = reconf(live, "discover", "--system", "unmodified", "-o", str(found))
    assert res.returncode == 0, res.stderr
    text = found.read_text()
    assert "node talker {" in text and "node listener {" in text and "count degraded: set report = false" in text
    assert reconf(live, "check", "--engine", "python", str(found)).returncode == 0
    res = reconf(live, "drift", UNMODIFIED)
    assert res.returncode == 0, res.stdout + res.stderr
    res = reconf(live, "down", UNMODIFIED, "--yes", "--log-dir", str(live.dir / "logs"))
    assert res.returncode == 0, res.stdout + res.stderr
    end = time.monotonic() + 10
    while any(alive(p) for p in pids) and time.monotonic() < end:
        time.sleep(0.1)
    assert [p for p in pids if alive(p)] == []
    assert live.violations() == {}


def test_a_wrapped_process_killed_mid_plan(live: LiveSystem) -> None:
    """The new talker's node is killed after its create: its adapter reports it and shuts down,
    and the rest of the plan is refused on what the executor observes, never reported done."""
    up(live)
    script = live.plan_script(["replace", "talker", "-f", UNMODIFIED])
    first = live.run_plan(script, "--to-step", "1", report="first.json")
    assert first.returncode == 0, first.stdout + first.stderr
    statuses = live.settle_status(["lc_talker"])
    os.kill(node_pid(statuses, "lc_talker"), 9)
    assert live.wait(lambda st: "SIGKILL" in st.get("/lc_talker", {}).get("values", {}).get("node.process", ""), 10)
    said = live.statuses()["/lc_talker"]
    assert "exited with signal SIGKILL" in said["message"], said
    rest = live.run_plan(script, "--from-step", "2", report="rest.json")
    assert rest.returncode == 1, rest.stdout + rest.stderr
    report = live.report("rest.json")
    assert report["outcome"] != "done", report
    assert "lc_talker" not in report["observed"]["components"], report["observed"]
    assert live.violations(live.settle_status(["talker", "listener"])) == {}


def test_executor_says_when_a_node_has_no_control_interface(live: LiveSystem) -> None:
    """A run line of a node reconf does not build, without its `node` block: the create fails at
    once, saying so in one line, not at the step's timeout; and a reconf input hears that plain
    node's volatile publisher all the same."""
    arch = live.dir / "undeclared.arch"
    text = Path(UNMODIFIED).read_text()
    arch.write_text(text.replace('  node talker {\n    out = /chatter  // its topic inside the executable\n  }\n', '')
                    .replace("node talker {\n    out = /chatter\n  }\n", ""))
    assert "node talker" not in arch.read_text()
    t0 = time.monotonic()
    res = reconf(live, "up", str(arch), "--yes", "--stop-started", "--log-dir", str(live.dir / "logs"))
    assert res.returncode == 1 and time.monotonic() - t0 < 25, res.stderr
    assert "serves no lifecycle services: not a reconf node" in res.stderr, res.stderr
    lifecycle = live.dir / "undeclared_lifecycle.arch"      # a lifecycle node: it configures, it activates…
    lifecycle.write_text("system lc\nmessage String = std_msgs/msg/String\n"
                         'component lc_talker {\n  run "python3 -m reconf_ros.demo.unmodified lc_talker"\n'
                         "  output out: String\n  functionality talk (out) { normal { out: String @ 10 Hz } "
                         "degraded { out: nothing } }\n}\ntopic /chatter: String @ 10 Hz { lc_talker.out -> }\n")
    res = reconf(live, "up", str(lifecycle), "--yes", "--stop-started", "--log-dir", str(live.dir / "logs"))
    assert res.returncode == 1, res.stderr        # …and has none of the interface's parameters: not "normal"
    assert "/lc_talker does not implement the control interface: no value for reconf.mode.talk" in res.stderr, \
        res.stderr
    plain = live.start([sys.executable, "-m", "reconf_ros.demo.unmodified", "talker"], "plain.log")
    live.deploy(example("chatter.arch"), ["listener"])
    live.wait_ready(["listener"])
    st = live.settle_status(["listener"])["/listener"]["values"]
    assert int(st["in.in.received"]) > 0 and "talker" in st["in.in.fresh"], st
    assert live.violations() == {}
    plain.terminate()
