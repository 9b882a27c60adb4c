"""What an adapter costs (docs/adapter.md#what-it-costs): one connector between two plain rclpy
nodes (bench/adapter_nodes.py), direct (publisher and subscriber on one topic) and relayed (each
node driven by its adapter, as `reconf up` runs them: node -> its adapter -> the connector -> the
other adapter -> node), for small messages at 10 Hz and 1 kHz and 1 MB messages at 30 Hz (a
camera).

Per case: messages in the window and lost (sequence gaps) on the relayed path; latency p50/p99
(the publisher's stamp to the subscriber's callback, one clock) of the direct path and of the
relayed one, each in a system of its own; the latency the relay adds, per message: on the
relayed system a third node reads the publisher's own (private) topic, so that each message's
arrival there and at the far end of the relay are compared under the same load; the relays'
CPU (user + system time over the window, of both adapter processes or of the relay process:
share of one core, and per message); the two nodes' CPU per message, direct and relayed; the
machine's load average when the row was measured (other work on its two cores is in the tails).

Besides the adapters, the other design (`--paths`): one relay process per host, both hops in
it, no control interface and no monitor, on rclpy's EventsExecutor or SingleThreadedExecutor. Targets: added p99 at most
2 ms at 10 Hz and 1 kHz, 5 ms for 1 MB at 30 Hz. Nodes run over the loopback profile
(docs/runtime.md#dds) in a domain of their own.

    python -m bench.bench_adapter [--seconds 20] [--only '1 kHz'] [--keep DIR]
"""
from __future__ import annotations

import argparse
import os
import statistics
import struct
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from reconf_ros.tools.livetest import LiveSystem

ROOT = Path(__file__).resolve().parent.parent
NODES = ROOT / "bench" / "adapter_nodes.py"
RECORD = struct.Struct("<ddd")
WARM_UP = 3.0          # s after both ends are up before the window opens
MESSAGES = 600         # at least this many in a window, for a p99 that is not the largest but a few
TICK = os.sysconf("SC_CLK_TCK")
# The subscriber assumes a tenth of the publisher's rate: its adapter's monitor measures every
# message, but a Python timer publishing at 1 kHz on two busy cores misses the 1.5 ms limit of a
# 1 kHz assumption hundreds of times a minute, and each miss is a status on /diagnostics.
ASSUMED = 10

# the relayed paths, one row each: the adapters, and the other design (one relay process per host)
PATHS = {"adapters": "two adapters (reconf)", "relay-single": "one relay process, SingleThreadedExecutor",
         "relay-events": "one relay process, EventsExecutor"}
# name, rate (Hz), message data (bytes), target for the added p99 (ms)
CASES = [("64 B at 10 Hz", 10.0, 64, 2.0), ("64 B at 1 kHz", 1000.0, 64, 2.0),
         ("1 MB at 30 Hz", 30.0, 1 << 20, 5.0)]

ARCH = """system bench

message Image = sensor_msgs/msg/Image

component source {{
  run "{python} {nodes} pub --rate {rate} --size {size}"
  node bench_pub {{
    out = /bench
  }}
  output out: Image

  functionality send (out) {{
    normal {{ out: Image @ {rate} Hz }}
    degraded {{ out: nothing }}
  }}
}}

component sink {{
  run "{python} {nodes} sub --out {out}"
  node bench_sub {{
    in = /bench
  }}
  input in: Image @ {assumed} Hz

  functionality take (in) {{
    normal {{ assume Image @ {assumed} Hz }}
    degraded {{ }}
  }}
}}

topic /bench: Image @ {rate} Hz {{
  source.out -> sink.in
}}
"""


def cpu(pid: int) -> float:
    """User + system seconds of process `pid` so far (0 once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICK


def records(path: Path) -> list[tuple[float, float, float]]:
    data = path.read_bytes() if path.exists() else b""
    return [RECORD.unpack_from(data, i) for i in range(0, len(data) - len(data) % RECORD.size, RECORD.size)]


def wait_records(path: Path, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if len(records(path)) >= 2:
            return True
        time.sleep(0.1)
    return False


def start_direct(live: LiveSystem, rate: float, size: int, out: Path) -> tuple[list[int], list[int]]:
    sub = live.start([sys.executable, str(NODES), "sub", "--out", str(out)], "sub.log")
    pub = live.start([sys.executable, str(NODES), "pub", "--rate", str(rate), "--size", str(size)], "pub.log")
    return [], [pub.pid, sub.pid]


def start_relayed(live: LiveSystem, rate: float, size: int, out: Path) -> tuple[list[int], list[int]]:
    """Each node under its adapter, one process each, brought up as the architecture deploys it;
    and a tap: a subscriber of the publisher's private topic (`tap.bin`), before the relay."""
    arch = live.dir / "bench.arch"
    rate_text = f"{rate:g}"
    arch.write_text(ARCH.format(python=sys.executable, nodes=NODES, rate=rate_text, assumed=f"{rate / ASSUMED:g}",
                                size=size, out=out))
    live.watch()
    adapters = [p.pid for p in live.deploy(str(arch), group=False)]
    normal = ("/source", "mode.send"), ("/sink", "mode.take")
    if not live.wait(lambda st: all(st.get(n, {}).get("values", {}).get(k) == "normal" for n, k in normal), 60):
        raise RuntimeError(f"the adapters did not come up: {live.statuses()}")
    st = live.statuses()
    live.start([sys.executable, str(NODES), "sub", "--out", str(out.with_name("tap.bin")), "--ros-args", "-r",
                f"bench:={st['/source']['values']['node']}/out", "-r", "__node:=bench_tap"], "tap.log")
    return adapters, [int(st[n]["values"]["node.pid"]) for n in ("/source", "/sink")]


def start_relay(live: LiveSystem, rate: float, size: int, out: Path, executor: str) -> tuple[list[int], list[int]]:
    """The other design: one relay process for the host, both hops in it (the connector's in between
    is then within one process), with `executor`; a tap on the publisher's own topic."""
    relay = live.start([sys.executable, str(NODES), "relay", "--executor", executor, "--ros-args", "-r",
                        "from:=/_pub/out", "-r", "to:=/_sub/in"], "relay.log")
    sub = live.start([sys.executable, str(NODES), "sub", "--out", str(out), "--ros-args", "-r", "bench:=/_sub/in"],
                     "sub.log")
    live.start([sys.executable, str(NODES), "sub", "--out", str(out.with_name("tap.bin")), "--ros-args", "-r",
                "bench:=/_pub/out", "-r", "__node:=bench_tap"], "tap.log")
    pub = live.start([sys.executable, str(NODES), "pub", "--rate", str(rate), "--size", str(size), "--ros-args",
                      "-r", "bench:=/_pub/out"], "pub.log")
    return [relay.pid], [pub.pid, sub.pid]


def measure(rate: float, size: int, how: str, work: Path, seconds: float) -> dict[str, Any]:
    """One path: `direct`, `adapters`, or `relay-events` / `relay-single` (the other design)."""
    out = work / "latency.bin"
    with LiveSystem(work) as live:
        if how.startswith("relay-"):
            adapters, nodes = start_relay(live, rate, size, out, how.split("-", 1)[1])
        else:
            adapters, nodes = (start_relayed if how == "adapters" else start_direct)(live, rate, size, out)
        if not wait_records(out, 60):
            raise RuntimeError(f"no message reached the subscriber ({how}): see {work}")
        time.sleep(WARM_UP)
        t0, a0, n0 = time.time(), sum(map(cpu, adapters)), sum(map(cpu, nodes))
        time.sleep(seconds)
        t1, a1, n1 = time.time(), sum(map(cpu, adapters)), sum(map(cpu, nodes))
    window = [r for r in records(out) if t0 <= r[0] < t1]
    seqs = sorted(int(r[2]) for r in window)
    n = len(window)
    tap = {int(r[2]): r[0] for r in records(out.with_name("tap.bin"))}
    return {"n": n, "lost": (seqs[-1] - seqs[0] + 1 - n) if seqs else 0,
            "lat": sorted(r[1] * 1000 for r in window),
            "added": sorted((r[0] - tap[int(r[2])]) * 1000 for r in window if int(r[2]) in tap),
            "adapters_cpu": (a1 - a0) / (t1 - t0), "load": float(Path("/proc/loadavg").read_text().split()[0]), "adapters_us": (a1 - a0) / n * 1e6 if n else float("nan"),
            "nodes_us": (n1 - n0) / n * 1e6 if n else float("nan")}


def pct(xs: list[float], q: float) -> float:
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def row(name: str, how: str, direct: dict[str, Any], relayed: dict[str, Any], target: float) -> str:
    def p(xs: list[float]) -> str:
        return f"{statistics.median(xs):.2f} / {pct(xs, 0.99):.2f}" if xs else "-"
    added = relayed["added"]
    verdict = "-" if not added else f"{'met' if pct(added, 0.99) <= target else 'NOT met'} (≤ {target:g})"
    return (f"| {name} | {how} | {relayed['n']} | {relayed['lost']} | {p(direct['lat'])} | {p(relayed['lat'])} | "
            f"{p(added)} | {verdict} | {relayed['adapters_cpu'] * 100:.1f} % ({relayed['adapters_us']:.0f} µs) | "
            f"{direct['nodes_us']:.0f} / {relayed['nodes_us']:.0f} | {relayed['load']:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=20.0,
                    help=f"the measured window of each case and path (at least {MESSAGES} messages)")
    ap.add_argument("--only", default="", help="cases whose name contains this")
    ap.add_argument("--paths", default=",".join(PATHS), help="relayed paths, one row each: " + ", ".join(PATHS))
    ap.add_argument("--keep", default="", help="keep each run's logs and records under this directory")
    args = ap.parse_args()
    cases = [c for c in CASES if args.only in c[0]]
    if not cases:
        sys.exit(f"no case matches {args.only!r}: {', '.join(c[0] for c in CASES)}")
    print("| case | relayed by | messages | lost | direct p50 / p99 ms | relayed p50 / p99 ms | added p50 / p99 ms | "
          "added p99 target ms | relays' CPU: share of a core (per message) | nodes' CPU µs per message, "
          "direct / relayed | load average |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.keep or tmp)
        for k, (name, rate, size, target) in enumerate(cases):
            seconds = max(args.seconds, MESSAGES / rate)
            direct = measure(rate, size, "direct", base / f"case{k}-direct", seconds)
            for how in args.paths.split(","):
                relayed = measure(rate, size, how, base / f"case{k}-{how}", seconds)
                print(row(name, PATHS[how], direct, relayed, target), flush=True)
    print("(latency: the publisher's stamp to the subscriber's callback; added: per message, its arrival through "
          "two adapters minus its arrival at a subscriber of the publisher's own topic; CPU: user + system time "
          "over the window)")


if __name__ == "__main__":
    main()
