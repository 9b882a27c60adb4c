"""An independent probe of a live reconf graph, for the fault campaign (`bench/bench_faults.py`):
its own rclpy code, none of the executor's (`reconf_ros/executor/`), so that what a run report
or `reconf recover --live` says of the system is checked against a second reading.

It waits for discovery (4 s, then the node list unchanged for 1.5 s, 12 s at most), listens to
`/diagnostics` for each node's status (the component it declares, its creation mark, its pid),
and asks every node that is not hidden (a name starting with `_`): its lifecycle state
(`get_state`), its `reconf.model`, and the `reconf.mode.*` and `reconf.port.*` that model names.
A node that does not answer (its service not offered, or no reply) within 12 s is asked again
once every other node has been read (a loaded machine can take that long to match a new
participant's endpoints); one that still does not is written as such, with why, never guessed at.

    python -m bench.probe [--out FILE]      # JSON: {"nodes": {fqn: {...}}, "seconds": ...}
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any, Optional

from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.ir import Component
from reconf_dsl.parser import parse_text

PATIENCE, WAIT = 12.0, 2.0     # per call: all the time given, each wait within it


def _names(model: str) -> tuple[list[str], list[str]]:
    """The functionalities and ports of the component a reconf.model text declares."""
    try:
        doc = parse_text(model, "<reconf.model>")
    except DiagnosticError:
        return [], []
    comp = next((it for it in doc.items if isinstance(it, Component)), None)
    return ([f.name for f in comp.functionalities], [p.name for p in comp.ports]) if comp else ([], [])


class Probe:
    def __init__(self) -> None:
        import os

        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        self.rclpy = rclpy
        rclpy.init()
        self.node = rclpy.create_node(f"_fault_probe_{os.getpid()}")
        self.statuses: dict[str, dict[str, str]] = {}
        self.why = ""
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._status, qos)

    def _status(self, msg: Any) -> None:
        for st in msg.status:
            if st.name.startswith("reconf:"):
                self.statuses[st.name[len("reconf:"):]] = {kv.key: kv.value for kv in st.values}

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)

    def graph(self) -> list[str]:
        return sorted(f"{ns.rstrip('/')}/{n}" for n, ns in self.node.get_node_names_and_namespaces()
                      if not n.startswith("_"))

    def settle(self) -> list[str]:
        self.spin(4.0)
        seen, since, end = self.graph(), time.monotonic(), time.monotonic() + 8.0
        while time.monotonic() < end and time.monotonic() - since < 1.5:
            self.spin(0.1)
            now = self.graph()
            if now != seen:
                seen, since = now, time.monotonic()
        self.spin(1.2)      # a status from every node (each repeats its own once a second)
        return self.graph()

    def call(self, srv: Any, name: str, req: Any) -> Optional[Any]:
        """The reply to `req`, or None (and why in self.why) when none came within PATIENCE s."""
        cli: Any = self.node.create_client(srv, name)
        end, offered = time.monotonic() + PATIENCE, False
        try:
            while time.monotonic() < end:
                if not cli.wait_for_service(timeout_sec=WAIT):
                    continue
                offered = True
                fut = cli.call_async(req)
                self.rclpy.spin_until_future_complete(self.node, fut, timeout_sec=WAIT)
                if fut.done() and fut.exception() is None:
                    return fut.result()
            self.why = f"{name}: {'no reply' if offered else 'not offered'} in {PATIENCE:.0f} s"
            return None
        finally:
            self.node.destroy_client(cli)

    def params(self, fqn: str, names: list[str]) -> Optional[dict[str, Any]]:
        from rcl_interfaces.msg import ParameterType
        from rcl_interfaces.srv import GetParameters
        req = GetParameters.Request()
        req.names = names
        res = self.call(GetParameters, f"{fqn}/get_parameters", req)
        if res is None or len(res.values) != len(names):
            self.why = self.why if res is None else f"{fqn}: {len(res.values)} values for {len(names)} names"
            return None
        out: dict[str, Any] = {}
        for n, v in zip(names, res.values):
            if v.type == ParameterType.PARAMETER_STRING:
                out[n] = v.string_value
            elif v.type == ParameterType.PARAMETER_STRING_ARRAY:
                out[n] = sorted(v.string_array_value)
        return out

    def read(self, fqn: str) -> dict[str, Any]:
        from lifecycle_msgs.srv import GetState
        st = self.statuses.get(fqn, {})
        info: dict[str, Any] = {"component": st.get("component"), "created": st.get("created"),
                                "pid": int(st["pid"]) if st.get("pid", "").isdigit() else None}
        res = self.call(GetState, f"{fqn}/get_state", GetState.Request())
        if res is None:
            return {**info, "answered": False, "why": self.why}
        info["lifecycle"] = str(res.current_state.label)
        model = self.params(fqn, ["reconf.model"])
        if not model or not model.get("reconf.model"):
            return {**info, "answered": model is not None, "model": None}
        funcs, ports = _names(model["reconf.model"])
        values = self.params(fqn, [f"reconf.mode.{f}" for f in funcs] + [f"reconf.port.{p}" for p in ports])
        if values is None:
            return {**info, "answered": False, "why": self.why}
        info.update(answered=True, model=model["reconf.model"],
                    modes={n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.mode.")},
                    ports={n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.port.")})
        return info

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.shutdown()


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.probe", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="", help="write the JSON here (default: stdout)")
    args = ap.parse_args(argv)
    t0 = time.monotonic()
    probe = Probe()
    try:
        nodes = {fqn: probe.read(fqn) for fqn in probe.settle()}
        for fqn in [f for f, info in nodes.items() if not info["answered"]]:
            nodes[fqn] = {**probe.read(fqn), "asked": 2}
    finally:
        probe.close()
    text = json.dumps({"nodes": nodes, "seconds": round(time.monotonic() - t0, 2)}, indent=1, sort_keys=True)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
