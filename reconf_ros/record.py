"""`python -m reconf_ros.record OUT --topic /chatter [--topic ...] --duration S`: a rosbag2
recording made with rclpy and rosbags, where there is no `ros2 bag` (docs/recordings.md#recording).

Each topic is subscribed raw (the serialized CDR bytes are written as they came, never decoded)
with the type its publishers have in the graph, at a QoS they all offer; recording starts once
every topic's publishers are matched (within --wait s, else exit 2) and lasts --duration s. A
message's log time is the middleware's receive time. SIGTERM or SIGINT ends it early, the
recording closed and readable. OUT is a new directory (metadata.yaml and one .db3 or .mcap)."""
from __future__ import annotations

import argparse
import importlib
import signal
import sys
import time
from pathlib import Path
from typing import Any, Optional

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m reconf_ros.record", description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the recording's directory (must not exist)")
    p.add_argument("--topic", action="append", required=True, help="a topic to record (repeatable)")
    p.add_argument("--duration", type=float, required=True, help="seconds to record once every topic is matched")
    p.add_argument("--storage", choices=["sqlite3", "mcap"], default="sqlite3")
    p.add_argument("--wait", type=float, default=20.0, help="seconds to wait for each topic's publishers")
    return p


def message_class(ros_type: str) -> Any:
    """The rclpy message class of `pkg/msg/Type`."""
    pkg, kind, name = ros_type.split("/")
    return getattr(importlib.import_module(f"{pkg}.{kind}"), name)


def _publishers(node: Any, topics: list[str], wait: float) -> dict[str, list[Any]]:
    """Each topic's publishers in the graph, once every topic has one (or after `wait` s)."""
    import rclpy
    end = time.monotonic() + wait
    found: dict[str, list[Any]] = {}
    while time.monotonic() < end:
        found = {t: node.get_publishers_info_by_topic(t) for t in topics}
        if all(found.values()):
            break
        rclpy.spin_once(node, timeout_sec=0.1)
    return found


def _qos(infos: list[Any]) -> Any:
    """Volatile, reliable when every publisher is (a best-effort one matches only best-effort)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, durability=DurabilityPolicy.VOLATILE,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT)


class Recorder:
    """The open recording: one connection per topic, messages written as they arrive."""

    def __init__(self, out: Path, storage: str) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore
        self.store = get_typestore(Stores.LATEST)
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.writer = Writer(out, version=9, storage_plugin=plugin)
        self.writer.open()
        self.conns: dict[str, Any] = {}
        self.last = 0
        self.count = 0

    def add(self, topic: str, ros_type: str) -> None:
        if ros_type in self.store.types:
            self.conns[topic] = self.writer.add_connection(topic, ros_type, typestore=self.store)
        else:       # a type rosbags does not know: recorded without its definition
            self.conns[topic] = self.writer.add_connection(topic, ros_type, msgdef="", rihs01="")

    def write(self, topic: str, data: bytes, info: Any) -> None:
        stamp = info.get("received_timestamp") if isinstance(info, dict) else None
        stamp = max(int(stamp or time.time_ns()), self.last)     # in time order, as a reader expects
        self.writer.write(self.conns[topic], stamp, data)
        self.last = stamp
        self.count += 1

    def close(self) -> None:
        self.writer.close()


def record(out: Path, topics: list[str], duration: float, storage: str, wait: float) -> int:
    import rclpy
    rclpy.init()
    node = rclpy.create_node("reconf_record")
    stop = {"now": False}
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.update(now=True))
    try:
        infos = _publishers(node, topics, wait)
        missing = [t for t in topics if not infos.get(t)]
        if missing:
            print(f"no publisher of {', '.join(missing)} within {wait:g} s: nothing recorded", file=sys.stderr)
            return 2
        rec = Recorder(out, storage)
        subs = []
        for t in topics:
            ros_type = infos[t][0].topic_type
            rec.add(t, ros_type)
            subs.append(node.create_subscription(message_class(ros_type), t,
                                                 lambda data, info, t=t: rec.write(t, data, info),
                                                 _qos(infos[t]), raw=True))
        end = time.monotonic() + wait
        while any(s.get_publisher_count() == 0 for s in subs) and time.monotonic() < end and not stop["now"]:
            rclpy.spin_once(node, timeout_sec=0.05)
        print(f"recording {', '.join(topics)} for {duration:g} s", flush=True)
        end = time.monotonic() + duration
        while time.monotonic() < end and not stop["now"]:
            rclpy.spin_once(node, timeout_sec=min(0.1, max(0.0, end - time.monotonic())))
        rec.close()
        print(f"wrote {out}: {rec.count} messages", flush=True)
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def main(argv: Optional[list[str]] = None) -> int:
    args = _parser().parse_args(argv)
    out = Path(args.out)
    if out.exists():
        print(f"{out} exists: a recording is written to a new directory", file=sys.stderr)
        return 2
    return record(out, args.topic, args.duration, args.storage, args.wait)


if __name__ == "__main__":
    sys.exit(main())
