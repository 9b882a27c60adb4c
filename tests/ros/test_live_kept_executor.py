"""The node processes' executor (reconf_ros.nodes.kept_executor, docs/runtime.md#cost) against its
contract, in a process of its own: every kind of callback runs as rclpy's own executor runs it,
entities made or destroyed in a callback are waited on, or no longer, from the next wake-up, a
coroutine that awaits is resumed, and after `shutdown` the nodes' destruction is not held back."""
from __future__ import annotations

from reconf_ros.tools.livetest import LiveSystem

from .conftest import run_script

SCRIPT = r"""import json, time
import rclpy
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.qos import QoSProfile
from std_msgs.msg import String
from std_srvs.srv import Trigger
from reconf_ros.nodes.kept_executor import KeptExecutor

rclpy.init()
ex = KeptExecutor()
a, b = rclpy.create_node("kept_a"), rclpy.create_node("kept_b")
ex.add_node(a)
ex.add_node(b)
seen = {"timer": 0, "info": [], "late": [], "matched": 0, "service": 0, "reply": None, "guard": 0, "awaited": None,
        "after_destroy": 0}
qos = QoSProfile(depth=10)
pub = a.create_publisher(String, "chat", qos, event_callbacks=PublisherEventCallbacks(
    matched=lambda info: seen.__setitem__("matched", info.current_count)))
late_pub = a.create_publisher(String, "late", qos)
b.create_subscription(String, "chat", lambda m, info: seen["info"].append((m.data, "received_timestamp" in info)), qos)
made = {}

def tick():
    seen["timer"] += 1
    pub.publish(String(data=f"m{seen['timer']}"))
    if seen["timer"] == 3:       # made in a callback: waited on from the next wake-up
        made["late"] = b.create_subscription(String, "late", lambda m: seen["late"].append(m.data), qos)
    late_pub.publish(String(data=f"l{seen['timer']}"))
a.create_timer(0.02, tick)

def serve(req, resp):
    seen["service"] += 1
    resp.success, resp.message = True, "served"
    return resp
b.create_service(Trigger, "kept_srv", serve)
client = a.create_client(Trigger, "kept_srv")
guard = b.create_guard_condition(lambda: seen.__setitem__("guard", seen["guard"] + 1))

async def awaiting():           # a coroutine that awaits a client's future: resumed by the executor
    resp = await client.call_async(Trigger.Request())
    seen["awaited"] = resp.message

deadline = time.time() + 20
while time.time() < deadline and not (seen["awaited"] and len(seen["late"]) >= 3 and seen["matched"]):
    if seen["timer"] >= 5 and "guard" not in made:
        made["guard"] = guard.trigger()
    if "task" not in made and client.service_is_ready():
        made["task"] = ex.create_task(awaiting)
    ex.spin_once(timeout_sec=0.05)
# a subscription destroyed in a callback is not called again
victim = made.pop("late")
def destroy():
    if "late_at_destroy" not in seen:
        b.destroy_subscription(victim)
        seen["late_at_destroy"] = len(seen["late"])
b.create_timer(0.001, destroy)
end = time.time() + 0.5
while time.time() < end:
    ex.spin_once(timeout_sec=0.05)
seen["after_destroy"] = len(seen["late"]) - seen.get("late_at_destroy", 0)
t = time.time()
ex.shutdown(timeout_sec=0)
a.destroy_node()
b.destroy_node()
seen["destroy_s"] = time.time() - t
rclpy.shutdown()
print(json.dumps(seen))
"""


def test_the_kept_executor_runs_every_kind_of_callback(live: LiveSystem) -> None:
    seen = run_script(live, SCRIPT, timeout=60)
    assert seen["timer"] >= 5
    assert seen["matched"] == 1                                     # a publisher's event
    assert seen["info"] and all(with_info for _, with_info in seen["info"]), seen["info"][:3]   # message info
    numbers = [int(d[1:]) for d, _ in seen["info"]]
    assert numbers == sorted(set(numbers))                          # in order, each once
    assert len(seen["late"]) >= 3                                   # a subscription made in a callback
    assert seen["service"] >= 1 and seen["awaited"] == "served"     # a service, a client, an awaiting coroutine
    assert seen["guard"] == 1
    assert seen["after_destroy"] == 0                               # destroyed in a callback: never called again
    assert seen["destroy_s"] < 1.0
