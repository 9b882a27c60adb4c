"""A plain rclpy node, not built with reconf_ros: what `reconf discover` finds with placeholders
(docs/runtime.md#discover). It counts what it hears on /chatter and publishes the count on
/heard at 2 Hz.

    python -m reconf_ros.demo.plain [--ros-args -r __node:=NAME]
"""
from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from std_msgs.msg import Int32, String


def main() -> None:
    rclpy.init(args=sys.argv)
    node = rclpy.create_node("counter")
    count = [0]

    def heard(msg: String) -> None:
        count[0] += 1

    node.create_subscription(String, "/chatter", heard, 10)
    pub = node.create_publisher(Int32, "/heard", 10)
    node.create_timer(0.5, lambda: pub.publish(Int32(data=count[0])))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
