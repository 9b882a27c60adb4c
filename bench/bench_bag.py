"""`reconf check --bag` on large recordings: time and memory against the recording's length.

    python -m bench.bench_bag [--sizes 0.25,0.5,1] [--storages sqlite3,mcap] [--dir DIR]

For each size (GiB) and storage, a recording is written with rosbags' Writer in a temporary
directory: /camera (sensor_msgs/Image, 640x480 mono, 300 KiB each) at 30 Hz, /scan
(std_msgs/String of 8 KiB) at 40 Hz and /chatter (std_msgs/String) at 10 Hz, real CDR bytes,
log times as a recorder would give them. Then `reconf check MODEL --bag REC --engine python`
runs in a fresh process, and the table gives its wall time and peak RSS (getrusage of that
child, by os.wait4): memory that does not grow with the size is the streaming read working.
Each recording is removed once measured (docs/recordings.md#cost).
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MODEL = """system bench
message String = std_msgs/msg/String
message Image = sensor_msgs/msg/Image
environment camera: Image @ 30 Hz
component talker {
  output out: String
  functionality talk (out) {
    normal { out: String @ 10 Hz }
    degraded { out: nothing }
  }
}
component listener {
  input in: String @ 10 Hz
  functionality listen (in) {
    normal { assume String @ 10 Hz }
    degraded { }
  }
}
topic /chatter: String @ 10 Hz { talker.out -> listener.in }
topic /scan: String @ 40 Hz { }
"""

GIB = 1 << 30
START = 1_700_000_000 * 10**9


def payloads() -> dict[str, tuple[str, bytes, int]]:
    """topic -> (type, CDR bytes, period in ns)."""
    import numpy as np
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="camera")
    image = T["sensor_msgs/msg/Image"](header=header, height=480, width=640, encoding="mono8", is_bigendian=0,
                                       step=640, data=np.zeros(640 * 480, dtype=np.uint8))
    def cdr(msg: object, t: str) -> bytes:
        return bytes(store.serialize_cdr(msg, t))
    return {"/camera": ("sensor_msgs/msg/Image", cdr(image, "sensor_msgs/msg/Image"), 10**9 // 30),
            "/scan": ("std_msgs/msg/String", cdr(T["std_msgs/msg/String"](data="x" * 8192), "std_msgs/msg/String"),
                      10**9 // 40),
            "/chatter": ("std_msgs/msg/String", cdr(T["std_msgs/msg/String"](data="hello"), "std_msgs/msg/String"),
                         10**9 // 10)}


def write(path: Path, size: int, storage: str) -> tuple[int, int]:
    """A recording of about `size` bytes at `path`; (messages, bytes on disk)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    topics = payloads()
    per_second = sum(len(data) * 10**9 // period for _, data, period in topics.values())
    seconds = max(1, size // per_second)
    n = 0
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns = {t: (w.add_connection(t, typ, typestore=store), data, period) for t, (typ, data, period) in topics.items()}
        events = sorted((k * period + 137 * (k % 7), t) for t, (_, _, period) in conns.items()
                        for k in range(seconds * 10**9 // period))
        for stamp, t in events:
            conn, data, _ = conns[t]
            w.write(conn, START + stamp, data)
            n += 1
    return n, sum(f.stat().st_size for f in path.iterdir())


def measure(model: Path, bag: Path) -> tuple[float, float, int]:
    """(wall s, peak RSS MiB, exit code) of `reconf check --bag` in a fresh process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "checker", "check", str(model), "--engine", "python",
                             "--bag", str(bag)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    return wall, usage.ru_maxrss / 1024, proc.returncode


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_bag", description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="0.25,0.5,1", help="recording sizes in GiB")
    ap.add_argument("--storages", default="sqlite3,mcap")
    ap.add_argument("--dir", default=None, help="where the recordings are written (default: a temporary directory)")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="reconf-bench-bag-", dir=args.dir))
    try:
        model = tmp / "bench.arch"
        model.write_text(MODEL, encoding="utf-8")
        print(f"{'storage':8} {'size MiB':>9} {'messages':>9} {'seconds':>8} {'write s':>8} {'check s':>8} "
              f"{'MiB/s':>7} {'peak RSS MiB':>13} {'exit':>5}")
        for storage in args.storages.split(","):
            for size in (float(s) for s in args.sizes.split(",")):
                bag = tmp / f"rec-{storage}-{size}"
                t0 = time.perf_counter()
                n, nbytes = write(bag, int(size * GIB), storage)
                wrote = time.perf_counter() - t0
                wall, rss, code = measure(model, bag)
                secs = n / (30 + 40 + 10)
                print(f"{storage:8} {nbytes / 2**20:9.0f} {n:9,} {secs:8.0f} {wrote:8.1f} {wall:8.2f} "
                      f"{nbytes / 2**20 / wall:7.0f} {rss:13.1f} {code:5}", flush=True)
                shutil.rmtree(bag)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
