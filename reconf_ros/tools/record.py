"""`python -m reconf_ros.tools.record OUT --topic /chatter [--topic ...] --duration S`: a rosbag2
recording made with rclpy and rosbags, where there is no `ros2 bag` (docs/recordings.md#recording).

Each topic is subscribed raw (the serialized CDR bytes are written as they came, never decoded)
with the type its publishers have in the graph, at a QoS they all offer. Recording starts once
every topic's publishers are matched (within --wait s, else exit 2; what arrives before is
dropped, so every topic starts at once) and lasts --duration s; the start and the stop are
written in the recording's metadata (custom_data). A message's log time is the middleware's
receive time. SIGTERM or SIGINT ends it early, the recording complete; before recording starts
they are exit 130, nothing written. OUT is a new directory (metadata.yaml and one .db3 or .mcap),
written beside it and renamed into place when complete: on any failure, exit 2 with a message
and nothing left behind."""
from __future__ import annotations

import argparse
import importlib
import os
import shutil
import signal
import sys
import time
from pathlib import Path
from typing import Any, Callable, Optional

from checker.reality.bag import STARTED, STOPPED

from ..executor.status import tool_node

__all__ = ["main", "EXIT_OK", "EXIT_FAILED", "EXIT_INTERRUPTED"]

EXIT_OK, EXIT_FAILED, EXIT_INTERRUPTED = 0, 2, 130


class Refused(Exception):
    """Nothing recorded, for the reason given: exit 2."""


class Interrupted(Exception):
    """SIGINT or SIGTERM before recording started: exit 130."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m reconf_ros.tools.record", description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="the recording's directory (must not exist)")
    p.add_argument("--topic", action="append", required=True, help="a topic to record (repeatable)")
    p.add_argument("--duration", type=float, required=True, help="seconds to record once every topic is matched")
    p.add_argument("--storage", choices=["sqlite3", "mcap"], default="sqlite3")
    p.add_argument("--wait", type=float, default=20.0,
                   help="seconds to wait for every topic's publishers to be found and matched")
    return p


def message_class(ros_type: str) -> Any:
    """The rclpy message class of `pkg/msg/Type`; `Refused` when it has no Python package here."""
    try:
        pkg, kind, name = ros_type.split("/")
        return getattr(importlib.import_module(f"{pkg}.{kind}"), name)
    except (ValueError, ImportError, AttributeError) as e:
        raise Refused(f"the type {ros_type} has no Python message class here ({type(e).__name__}: {e}): "
                      "install its package") from None


def _until(deadline: float, stop: dict[str, bool], done: Callable[[], bool], spin: Callable[[], None]) -> bool:
    """Spin until `done()` (True) or the deadline (False); `Interrupted` on a signal."""
    while not done():
        if stop["now"]:
            raise Interrupted()
        if time.monotonic() >= deadline:
            return False
        spin()
    return True


def _qos(infos: list[Any]) -> Any:
    """Volatile, reliable when every publisher is (a best-effort one matches only best-effort)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, durability=DurabilityPolicy.VOLATILE,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT)


class Recorder:
    """The recording being written to `partial`: one connection per topic; messages are dropped
    until `begin()`, then written as they arrive; `finish(out)` closes it and renames it to out."""

    def __init__(self, partial: Path, storage: str) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore
        self.store = get_typestore(Stores.LATEST)
        self.partial = partial
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.writer = Writer(partial, version=9, storage_plugin=plugin)
        self.writer.open()
        self.conns: dict[str, Any] = {}
        self.started: Optional[int] = None
        self.last = 0
        self.count = 0

    def add(self, topic: str, ros_type: str) -> None:
        if ros_type in self.store.types:
            self.conns[topic] = self.writer.add_connection(topic, ros_type, typestore=self.store)
        else:       # a type rosbags does not know: recorded without its definition
            self.conns[topic] = self.writer.add_connection(topic, ros_type, msgdef="", rihs01="")

    def begin(self) -> None:
        self.started = self.last = time.time_ns()

    def write(self, topic: str, data: bytes, info: Any) -> None:
        stamp = info.get("received_timestamp") if isinstance(info, dict) else None
        stamp = int(stamp or time.time_ns())
        if self.started is None or stamp < self.started:
            return                     # before every topic was matched: dropped
        stamp = max(stamp, self.last)  # in time order, as a reader expects
        self.writer.write(self.conns[topic], stamp, data)
        self.last = stamp
        self.count += 1

    def finish(self, out: Path) -> None:
        assert self.started is not None
        self.writer.set_custom_data(STARTED, str(self.started))
        self.writer.set_custom_data(STOPPED, str(max(time.time_ns(), self.last)))
        self.writer.close()
        if out.exists():
            raise Refused(f"{out} appeared while recording: the recording is not moved over it")
        os.rename(self.partial, out)

    def abort(self) -> None:
        try:
            self.writer.close()
        except Exception:
            pass
        shutil.rmtree(self.partial, ignore_errors=True)


def _subscribe(node: Any, rec: Recorder, topics: list[str], infos: dict[str, list[Any]]) -> list[Any]:
    subs = []
    for t in topics:
        ros_type = infos[t][0].topic_type
        try:
            cls = message_class(ros_type)
        except Refused as e:
            raise Refused(f"cannot record {t}: {e}") from None
        rec.add(t, ros_type)
        subs.append(node.create_subscription(cls, t, lambda data, info, t=t: rec.write(t, data, info),
                                             _qos(infos[t]), raw=True))
    return subs


def record(out: Path, topics: list[str], duration: float, storage: str, wait: float, stop: dict[str, bool]) -> int:
    """Record `topics` into `out`; the exit code (`Refused`, `Interrupted` raised)."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(tool_node("record"))     # hidden: a tool of reconf's, not a component
    rec: Optional[Recorder] = None
    try:
        print(f"waiting for the publishers of {', '.join(topics)} (at most {wait:g} s)", flush=True)
        deadline = time.monotonic() + wait
        infos: dict[str, list[Any]] = {}

        def found() -> bool:
            infos.update({t: node.get_publishers_info_by_topic(t) for t in topics})
            return all(infos.values())

        def spin() -> None:
            rclpy.spin_once(node, timeout_sec=0.05)
        if not _until(deadline, stop, found, spin):
            missing = [t for t in topics if not infos.get(t)]
            raise Refused(f"no publisher of {', '.join(missing)} within {wait:g} s: nothing recorded")
        rec = Recorder(out.parent / f".{out.name}.partial-{os.getpid()}", storage)
        subs = _subscribe(node, rec, topics, infos)
        if not _until(deadline, stop, lambda: all(s.get_publisher_count() > 0 for s in subs), spin):
            late = [t for t, s in zip(topics, subs) if s.get_publisher_count() == 0]
            raise Refused(f"{', '.join(late)}: publishers found but not matched within {wait:g} s: nothing recorded")
        rec.begin()
        print(f"recording {', '.join(topics)} for {duration:g} s", flush=True)
        end = time.monotonic() + duration
        while time.monotonic() < end and not stop["now"]:
            rclpy.spin_once(node, timeout_sec=min(0.1, max(0.0, end - time.monotonic())))
        rec.finish(out)
        print(f"wrote {out}: {rec.count} messages", flush=True)
        rec = None
        return EXIT_OK
    finally:
        if rec is not None:
            rec.abort()
        node.destroy_node()
        rclpy.try_shutdown()


def main(argv: Optional[list[str]] = None) -> int:
    args = _parser().parse_args(argv)
    out = Path(args.out)
    if out.exists():
        print(f"{out} exists: a recording is written to a new directory", file=sys.stderr)
        return EXIT_FAILED
    if not out.parent.is_dir():
        print(f"{out.parent} is not a directory: the recording cannot be written there", file=sys.stderr)
        return EXIT_FAILED
    stop = {"now": False}
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.update(now=True))
    try:
        return record(out, args.topic, args.duration, args.storage, args.wait, stop)
    except Refused as e:
        print(str(e), file=sys.stderr)
        return EXIT_FAILED
    except Interrupted:
        print("interrupted before recording started: nothing recorded", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as e:     # rclpy, the middleware, the disk: said in one line, never a traceback
        print(f"cannot record {out}: {type(e).__name__}: {e}", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
