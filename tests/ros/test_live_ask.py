"""An asked status (docs/control-interface.md#asked-status), on the wire: a node asked for one of its
inputs publishes its status at the first message after the ask's time, from each publisher,
without waiting for its periodic status; unasked, it says nothing new until that status. The
nodes' status period is 30 s here, so only an answer to an ask can show a reception after it."""
from __future__ import annotations

from reconf_ros.tools.livetest import LiveSystem

from .conftest import run_script

SCRIPT = r"""import json, time
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import String
from reconf_ros.demo.chatter import listener, talker
from reconf_ros.executor.status import ASK_TOPIC, STATUS_PREFIX, ask_text, parse_status
from reconf_ros.nodes.component import ASK_QOS, STATUS_QOS, ComponentNode
from reconf_ros.nodes.kept_executor import KeptExecutor

rclpy.init()
ex = KeptExecutor()
nodes = [ComponentNode(talker(), status_period=30.0, deployed={"out": ["/chatter"]}),
         ComponentNode(listener(), status_period=30.0, deployed={"in": ["/chatter"]})]
asker = rclpy.create_node("_reconf_asker")
statuses = []          # (when it came, the listener's status)
asker.create_subscription(DiagnosticArray, "/diagnostics", lambda m: statuses.extend(
    (time.time(), parse_status(s.values)) for s in m.status if s.name == STATUS_PREFIX + "/listener"), STATUS_QOS)
ask = asker.create_publisher(String, ASK_TOPIC, ASK_QOS)
for n in nodes + [asker]:
    ex.add_node(n)
for n in nodes:
    n.trigger_configure()
    n.trigger_activate()


def spin_until(cond, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end and not cond():
        ex.spin_once(timeout_sec=0.02)
    return cond()


def shows_after(since):
    return [at for at, st in statuses if float(st.get("in.in.last.talker") or 0) > since]


seen = {"heard": spin_until(lambda: any(st.get("mode.listen") == "normal" for _, st in statuses), 20.0),
        "matched": spin_until(lambda: ask.get_subscription_count() >= 2, 10.0)}
since = time.time()         # unasked: no status shows a reception after this
spin_until(lambda: shows_after(since), 1.5)
seen["unasked"] = len(shows_after(since))
seen["answers"] = []
for _ in range(5):
    since = time.time()
    ask.publish(String(data=ask_text(since, [("/listener", "in"), ("/elsewhere", "in")])))
    spin_until(lambda: shows_after(since), 2.0)
    got = shows_after(since)
    seen["answers"].append([round(t - since, 3) for t in got])
    spin_until(lambda: False, 0.3)
    seen["answers"][-1].append(len(shows_after(since)))   # one per publisher, not one per message
print(json.dumps(seen))
"""


def test_a_node_asked_for_an_input_s_status_answers_at_its_next_message(live: LiveSystem) -> None:
    seen = run_script(live, SCRIPT, timeout=90)
    assert seen["heard"] and seen["matched"], seen
    assert seen["unasked"] == 0, seen                  # the periodic status (30 s) shows nothing new
    for answer in seen["answers"]:
        *times, count = answer
        assert times and times[0] < 1.0, seen          # the talker's next message (10 Hz) and the status
        assert count == 1, seen
