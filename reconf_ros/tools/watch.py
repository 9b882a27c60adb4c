"""`python -m reconf_ros.tools.watch`: follow the components' statuses on /diagnostics.

Prints each violation of a normal mode's assumption as a monitor reports it, and with
`--out FILE` keeps FILE (JSON) updated with the last status of every component seen, which is
what the live tests and `bench/bench_live.py` read (docs/runtime.md).
"""
from __future__ import annotations

import json
import os
import signal
import sys
import time
from datetime import datetime
from typing import Any, Optional

import click

from ..executor.status import STATUS_PREFIX, parse_status, tool_node


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--out", type=click.Path(dir_okay=False), help="keep the last status of each component here (JSON)")
@click.option("--duration", type=float, default=0.0, help="stop after this many seconds (0: until SIGINT/SIGTERM)")
@click.option("--quiet", is_flag=True, help="print nothing; only --out")
def main(out: Optional[str], duration: float, quiet: bool) -> None:
    """Follow reconf components' statuses; report every violated assumption."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    rclpy.init()
    node = rclpy.create_node(tool_node("watch"))
    latest: dict[str, dict[str, Any]] = {}
    stop = {"now": False}

    def on_signal(signum: int, frame: Any) -> None:
        stop["now"] = True
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)

    def on_status(msg: Any) -> None:
        for st in msg.status:
            if not st.name.startswith(STATUS_PREFIX):
                continue
            name = st.name[len(STATUS_PREFIX):]
            values = parse_status(st.values)
            before = latest.get(name, {}).get("values", {})
            latest[name] = {"level": int.from_bytes(st.level, "little") if isinstance(st.level, bytes)
                            else int(st.level), "message": st.message, "values": values, "seen": time.time()}
            if not quiet and values.get("violations") != before.get("violations") and st.level == DiagnosticStatus.ERROR:
                click.echo(f"{datetime.now().strftime('%H:%M:%S.%f')[:-3]} {name}: {st.message}", err=True)

    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(DiagnosticArray, "/diagnostics", on_status, qos)
    end = time.monotonic() + duration if duration else float("inf")
    last_write = 0.0
    try:
        while not stop["now"] and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
            if out and time.monotonic() - last_write > 0.2:
                _write(out, latest)
                last_write = time.monotonic()
    finally:
        if out:
            _write(out, latest)
        node.destroy_node()
        rclpy.shutdown()
    sys.exit(0)


def _write(path: str, latest: dict[str, Any]) -> None:
    tmp = f"{path}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(latest, fh, sort_keys=True)
    os.replace(tmp, path)


if __name__ == "__main__":
    main()
