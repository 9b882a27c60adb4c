"""A plan script's end (docs/executor.md#discovery): it leaves its node's service clients to the
deletion of its participant as the process exits, and the other nodes see its node gone at once,
not after Fast DDS's lease of 20 s."""
from __future__ import annotations

import json
import subprocess
import sys
import time

from reconf_ros.tools.livetest import LiveSystem

# a plan script's runtime with the clients of a run, closed as a plan script closes it
SCRIPT = """import sys, time
from lifecycle_msgs.srv import GetState
from reconf_ros.executor.runtime import Runtime
rt = Runtime("exit_test", "", 5.0)
for i in range(40):
    rt.client(GetState, f"/node{i}/get_state")
rt.spin(1.5)
print(rt.node.get_name(), flush=True)
sys.stdin.readline()                    # the observer has seen the node
rt.close(exiting=True)
print(time.time(), flush=True)
"""

# another participant: when it saw the node, and when it saw it gone (wall clock)
OBSERVER = """import json, sys, time
import rclpy
rclpy.init()
node = rclpy.create_node("exit_observer")
name, seen, gone = sys.argv[1], None, None
deadline = time.time() + 40
while time.time() < deadline and gone is None:
    rclpy.spin_once(node, timeout_sec=0.02)
    names = {n for n, _ in node.get_node_names_and_namespaces()}
    if seen is None and name in names:
        seen = time.time()
        print("seen", flush=True)
    elif seen is not None and name not in names:
        gone = time.time()
print(json.dumps({"seen": seen, "gone": gone}), flush=True)
node.destroy_node()
rclpy.shutdown()
"""


def test_a_plan_script_s_node_is_seen_gone_as_its_process_exits(live: LiveSystem) -> None:
    script = subprocess.Popen([sys.executable, "-c", SCRIPT], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=live.env)
    live.pids.add(script.pid)
    assert script.stdin is not None and script.stdout is not None
    name = script.stdout.readline().strip()
    assert name.startswith("_reconf_plan_exit_test_"), script.communicate(timeout=30)
    observer = subprocess.Popen([sys.executable, "-c", OBSERVER, name], stdout=subprocess.PIPE, text=True,
                                env=live.env)
    live.pids.add(observer.pid)
    assert observer.stdout is not None
    assert observer.stdout.readline().strip() == "seen", observer.communicate(timeout=60)
    out, err = script.communicate("\n", timeout=30)
    exited = time.time()
    assert script.returncode == 0, err
    seen = json.loads(observer.communicate(timeout=60)[0])
    # gone within 2 s of the exit: a participant that vanished without its deletion stays 20 s
    assert seen["gone"] is not None and seen["gone"] - exited < 2.0, (seen, out, exited)
