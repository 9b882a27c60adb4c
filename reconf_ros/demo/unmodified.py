"""ROS 2 nodes as every project has them, written with rclpy alone and nothing of reconf: what
`examples/unmodified.arch` drives through adapters (docs/adapter.md). Each is the shape of a
common node: `talker` of demo_nodes_py (a plain node, a publisher and a timer), `lc_talker`
(a lifecycle node with a lifecycle publisher, as every Nav2 server is), `listener` (a plain
node that counts what it hears and publishes the count while its parameter `report` is true).

    python -m reconf_ros.demo.unmodified talker [--rate HZ] [--ros-args ...]
    python -m reconf_ros.demo.unmodified lc_talker [--rate HZ] [--size BYTES]
    python -m reconf_ros.demo.unmodified listener
    python -m reconf_ros.demo.unmodified sink

`--size` pads each message's text to that many bytes (the adapter's benchmark); `sink` is a
plain subscriber of `chatter` that does nothing else.
"""
from __future__ import annotations

import argparse
import sys
from typing import Any, Callable

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from std_msgs.msg import Int32, String

__all__ = ["main"]


def _text(n: int, size: int) -> str:
    text = f"hello {n}"
    return text + "." * max(0, size - len(text))


def talker(rate: float, size: int) -> Any:
    node = rclpy.create_node("talker")
    pub = node.create_publisher(String, "chatter", 10)
    n = [0]

    def tick() -> None:
        n[0] += 1
        pub.publish(String(data=_text(n[0], size)))
    node.create_timer(1.0 / rate, tick)
    return node


class LifecycleTalker(LifecycleNode):
    """Publishes while active (its lifecycle publisher drops what it is given otherwise)."""

    def __init__(self, rate: float, size: int) -> None:
        super().__init__("lc_talker")
        self.rate, self.size, self.n = rate, size, 0
        self.pub: Any = None
        self.timer: Any = None

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.pub = self.create_lifecycle_publisher(String, "chatter", 10)
        self.timer = self.create_timer(1.0 / self.rate, self.tick)
        return TransitionCallbackReturn.SUCCESS

    def tick(self) -> None:
        if self.pub is not None and self.pub.is_activated:
            self.n += 1
            self.pub.publish(String(data=_text(self.n, self.size)))

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.destroy_timer(self.timer)
        self.destroy_lifecycle_publisher(self.pub)
        self.pub = self.timer = None
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS


def listener(rate: float, size: int) -> Any:
    node = rclpy.create_node("listener")
    node.declare_parameter("report", True)
    count = [0]

    def heard(msg: String) -> None:
        count[0] += 1
    node.create_subscription(String, "chatter", heard, 10)
    pub = node.create_publisher(Int32, "heard", 10)

    def report() -> None:
        if node.get_parameter("report").value:
            pub.publish(Int32(data=count[0]))
    node.create_timer(0.5, report)
    return node


def sink(rate: float, size: int) -> Any:
    node = rclpy.create_node("sink")
    node.create_subscription(String, "chatter", lambda msg: None, 10)
    return node


NODES: dict[str, Callable[[float, int], Any]] = {"talker": talker, "lc_talker": LifecycleTalker,
                                                 "listener": listener, "sink": sink}


def main(argv: list[str] | None = None) -> None:
    args = sys.argv if argv is None else argv
    ours = args[1:args.index("--ros-args")] if "--ros-args" in args else args[1:]
    ap = argparse.ArgumentParser(prog="python -m reconf_ros.demo.unmodified")
    ap.add_argument("node", choices=sorted(NODES))
    ap.add_argument("--rate", type=float, default=10.0, help="messages per second (talkers)")
    ap.add_argument("--size", type=int, default=0, help="pad each message's text to this many bytes")
    opts = ap.parse_args(ours)
    rclpy.init(args=args)
    node = NODES[opts.node](opts.rate, opts.size)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
