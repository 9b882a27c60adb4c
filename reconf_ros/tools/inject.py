"""`python -m reconf_ros.tools.inject TOPIC [TIMEOUT]`: a node that publishes each line of its standard
input (a JSON document) on TOPIC as a std_msgs/String, volatile, once something subscribes.

It prints `ready` once a subscriber is matched (exit 1 if none within TIMEOUT s) and `sent N`
after each message, N the subscribers then. Started ahead of a fault's injection
(reconf_ros.tools.livetest.LiveSystem.injector), so the fault strikes when it is sent, not after a
process has started and been discovered."""
from __future__ import annotations

import sys
import threading
import time

__all__ = ["main"]


def main(argv: list[str]) -> int:
    import rclpy
    from std_msgs.msg import String

    from ..nodes.component import VOLATILE_QOS
    topic, timeout = argv[0], float(argv[1]) if len(argv) > 1 else 20.0
    rclpy.init()
    node = rclpy.create_node("reconf_inject")
    pub = node.create_publisher(String, topic, VOLATILE_QOS)
    end = time.monotonic() + timeout
    while pub.get_subscription_count() == 0:
        if time.monotonic() > end:
            print(f"nothing subscribes to {topic}", flush=True)
            return 1
        rclpy.spin_once(node, timeout_sec=0.05)
    print("ready", flush=True)
    spinner = threading.Thread(target=rclpy.spin, args=(node,), daemon=True)
    spinner.start()
    for line in sys.stdin:
        if line.strip():
            pub.publish(String(data=line.strip()))
            print(f"sent {pub.get_subscription_count()}", flush=True)
    time.sleep(0.5)     # let the last message leave before the participant goes
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
