"""The two plain rclpy nodes `bench_adapter` measures, connected directly or through adapters:
`pub` stamps each message (sensor_msgs/Image: its header the send time, its frame_id the
sequence number, `--size` bytes of data) at `--rate` Hz on `bench`; `sub` writes, per message,
its receive time, latency and sequence number to `--out` (binary doubles, flushed as it goes,
so that a process ended by SIGKILL still leaves what it measured).

    python bench/adapter_nodes.py pub --rate 1000 --size 64 [--ros-args ...]
    python bench/adapter_nodes.py sub --out FILE [--ros-args ...]
    python bench/adapter_nodes.py relay --executor events|single

`relay` is the other design `bench_adapter` measures: one process per host relaying, serialized,
`from` -> `bench` -> `to` (a node's topic to the connector, the connector to the other node's):
no control interface, no monitor, on rclpy's EventsExecutor or SingleThreadedExecutor.
"""
from __future__ import annotations

import argparse
import array
import struct
import sys
import time
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
RECORD = struct.Struct("<ddd")      # receive time, latency (s), sequence number


def pub(rate: float, size: int) -> Any:
    node = rclpy.create_node("bench_pub")
    out = node.create_publisher(Image, "bench", QOS)
    msg = Image(height=1, width=size, encoding="mono8", step=size)
    msg.data = array.array("B", bytes(size))
    seq = [0]

    def tick() -> None:
        seq[0] += 1
        now = time.time_ns()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
        msg.header.frame_id = str(seq[0])
        out.publish(msg)
    node.create_timer(1.0 / rate, tick)
    return node


def sub(path: str) -> Any:
    node = rclpy.create_node("bench_sub")
    fh = open(path, "ab", buffering=0)

    def got(msg: Image) -> None:
        now = time.time()
        sent = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        fh.write(RECORD.pack(now, now - sent, float(msg.header.frame_id or 0)))
    node.create_subscription(Image, "bench", got, QOS)
    return node


def relay() -> Any:
    node = rclpy.create_node("bench_relay")
    pubs = {"bench": node.create_publisher(Image, "bench", QOS), "to": node.create_publisher(Image, "to", QOS)}
    node.create_subscription(Image, "from", pubs["bench"].publish, QOS, raw=True)
    node.create_subscription(Image, "bench", pubs["to"].publish, QOS, raw=True)
    return node


def main() -> None:
    args = sys.argv
    ours = args[1:args.index("--ros-args")] if "--ros-args" in args else args[1:]
    ap = argparse.ArgumentParser(prog="bench/adapter_nodes.py")
    ap.add_argument("role", choices=["pub", "sub", "relay"])
    ap.add_argument("--executor", choices=["events", "single"], default="single")
    ap.add_argument("--rate", type=float, default=10.0)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--out", default="latency.bin")
    opts = ap.parse_args(ours)
    rclpy.init(args=args)
    node = pub(opts.rate, opts.size) if opts.role == "pub" else sub(opts.out) if opts.role == "sub" else relay()
    if opts.executor == "events":
        from rclpy.experimental import EventsExecutor
        executor: Any = EventsExecutor()
    else:
        from rclpy.executors import SingleThreadedExecutor
        executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while rclpy.ok():         # not rclpy.spin(): with the EventsExecutor it relays nothing (rclpy 9.1.2)
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
