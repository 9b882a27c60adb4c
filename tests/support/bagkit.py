"""Small rosbag2 recordings with real CDR messages, written by rosbags' Writer: the ones
committed in tests/data/bag/ (`python -m tests.support.bagkit` writes them again) and the ones a test
makes on the spot. Log times are whole nanoseconds from START, so windows fall where stated."""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Iterable, Optional, Sequence

DATA = Path(__file__).resolve().parents[1] / "data" / "bag"
START = 1_700_000_000 * 10**9
MS = 10**6


def stamps(hz: float, seconds: float, skip: Sequence[tuple[float, float]] = (), until: float = 1e9) -> list[int]:
    """Log times (ns from START) at `hz` for `seconds`, none in any [a, b) of `skip` nor from `until`."""
    n = int(round(seconds * hz))
    out = []
    for i in range(n):
        t = i / hz
        if t < until and not any(a <= t < b for a, b in skip):
            out.append(round(t * 1e9))
    return out


def message(store: Any, msgtype: str, i: int) -> bytes:
    """The CDR bytes of a small, real message of `msgtype`, the i-th of its topic."""
    T = store.types
    if msgtype == "std_msgs/msg/String":
        msg = T[msgtype](data=f"hello world: {i}")
    elif msgtype == "geometry_msgs/msg/Twist":
        v = T["geometry_msgs/msg/Vector3"]
        msg = T[msgtype](linear=v(x=0.1 * i, y=0.0, z=0.0), angular=v(x=0.0, y=0.0, z=0.2))
    elif msgtype == "sensor_msgs/msg/Image":
        import numpy as np
        t = T["builtin_interfaces/msg/Time"](sec=i // 30, nanosec=0)
        header = T["std_msgs/msg/Header"](stamp=t, frame_id="camera")
        msg = T[msgtype](header=header, height=2, width=2, encoding="mono8", is_bigendian=0, step=2,
                         data=np.arange(4, dtype=np.uint8))
    else:
        raise ValueError(msgtype)
    return bytes(store.serialize_cdr(msg, msgtype))


def write(path: Path, topics: Iterable[tuple[str, str, list[int]]], storage: str = "sqlite3",
          bounds: Optional[tuple[int, int]] = None) -> Path:
    """A recording at `path` (a directory) of each (topic, type, log times from START), in time order;
    with `bounds` (ns from START), the recorder's start and stop in custom_data, as reconf_ros.tools.record
    writes them."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from checker.reality.bag import STARTED, STOPPED
    store = get_typestore(Stores.ROS2_JAZZY)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    events = []
    with Writer(path, version=9, storage_plugin=plugin) as w:
        for key, t in zip((STARTED, STOPPED), bounds or ()):
            w.set_custom_data(key, str(START + t))
        for name, msgtype, times in topics:
            conn = w.add_connection(name, msgtype, typestore=store)
            events += [(t, name, i, conn, msgtype) for i, t in enumerate(times)]
        for t, _, i, conn, msgtype in sorted(events, key=lambda e: (e[0], e[1])):
            w.write(conn, START + t, message(store, msgtype, i))
    return path


def committed() -> list[tuple[str, str, list[int]]]:
    """What tests/data/bag's recordings hold, 6 s of it (tests/test_recording.py relies on each figure):
    /chatter at 10 Hz; /cmd_vel at 20 Hz with nothing in [3.0, 3.5) s; /camera at 30 Hz; /status
    at 10 Hz until 3 s, then silent to the end."""
    return [("/chatter", "std_msgs/msg/String", stamps(10, 6)),
            ("/cmd_vel", "geometry_msgs/msg/Twist", stamps(20, 6, skip=[(3.0, 3.5)])),
            ("/camera", "sensor_msgs/msg/Image", stamps(30, 6)),
            ("/status", "std_msgs/msg/String", stamps(10, 6, until=3.0))]


def main() -> int:
    import shutil
    import tempfile
    DATA.mkdir(parents=True, exist_ok=True)
    for storage, ext in (("sqlite3", "db3"), ("mcap", "mcap")):
        with tempfile.TemporaryDirectory() as tmp:
            out = write(Path(tmp) / "rec", committed(), storage)
            (f,) = [p for p in out.iterdir() if p.suffix == f".{ext}"]
            shutil.copyfile(f, DATA / f"six_seconds.{ext}")
            print(f"wrote {DATA / f'six_seconds.{ext}'}: {f.stat().st_size:,} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
