"""Crash detection and recovery of a duplex (paper 000 §5.2.2): the primary's crash detector
beats, the backup's raises an alarm when the beats stop, and Recovery makes the failed replica
fail-silent and binds the backup's outermost protocol to the proxy, through the control
interface (docs/control-interface.md), as a plan's attach does. The primary's detector is the
model-driven publisher of its beats (reconf_ros.ftm.BEHAVIOURS)."""
from __future__ import annotations

import re
from typing import Any, Optional

from reconf_dsl.ir import System

from ..model import Component
from .wire import Ports, now, unpack

__all__ = ["Detector", "Recovery", "MISSED_BEATS"]

MISSED_BEATS = 2.5      # heartbeat periods of silence before the backup's detector raises the alarm
ARM_AFTER = 1.0         # s of regular beats before it does: a start-up hiccup is not a crash


class Detector:
    """Raises one alarm when the primary's beats stop for MISSED_BEATS periods, once they have
    come regularly for ARM_AFTER seconds."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        hz = ports.input("beat").assumption.hz
        self.limit = MISSED_BEATS / float(hz) if hz else 0.25
        self.last: Optional[float] = None
        self.steady_since: Optional[float] = None    # regular beats since then
        self.alarmed_at: Optional[float] = None
        ports.input("beat").on_message(self.on_beat)
        comp.create_timer(20, self.check)

    def on_beat(self, msg: Any) -> None:
        t = now()
        if self.last is None or t - self.last > self.limit:
            self.steady_since = t
        self.last = t

    def check(self) -> None:
        if self.alarmed_at is not None or self.last is None or self.steady_since is None or not self.p.normal:
            return
        if self.last - self.steady_since < ARM_AFTER:
            return
        silent = now() - self.last
        if silent > self.limit and self.p.send("alarm", {"failed": "r0", "silent_s": round(silent, 3)}):
            self.alarmed_at = now()
            self.p.comp.node.get_logger().warning(f"no heartbeat for {silent:.3f} s: alarm raised")


class Recovery:
    """On the alarm: deactivate replica 0's nodes (fail-silent), attach replica 1's outermost
    protocol where replica 0's was (the proxy's requests and replies), and tell it."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p, self.comp = ports, comp
        server = comp.name.split("__", 1)[0]
        prefix = f"{server}__"
        names = [c.name for c in system.components]
        r0 = sorted((n for n in names if re.fullmatch(rf"{re.escape(prefix)}r0_\w+_protocol", n)), key=_layer)
        self.failed = [n for n in names if n.startswith(prefix + "r0_")] + [server]
        self.primary = r0[0] if r0 else ""
        self.backup = self.primary.replace("__r0_", "__r1_", 1)
        self.bindings: dict[str, list[str]] = {}
        for conn in system.connectors:
            for r in conn.roles:
                if r.component == self.primary and r.port in ("from_client", "reply"):
                    self.bindings.setdefault(r.port, []).append(conn.name)
        self.alarm_at: Optional[float] = None
        self.switched_at: Optional[float] = None
        self.clients: dict[str, Any] = {}
        self.calls: list[Any] = []
        ports.input("alarm").on_message(self.on_alarm)
        comp.create_timer(10, self.tick)

    def prepare(self) -> None:
        """Clients made ahead of time: a request sent before its service is matched is lost."""
        from lifecycle_msgs.srv import ChangeState
        from rcl_interfaces.srv import SetParameters
        node = self.comp.node
        ns = node.get_namespace().rstrip("/")
        self.clients = {name: node.create_client(ChangeState, f"{ns}/{name}/change_state") for name in self.failed}
        self.clients[""] = node.create_client(SetParameters, f"{ns}/{self.backup}/set_parameters")

    def on_alarm(self, msg: Any) -> None:
        if self.alarm_at is None and self.p.normal and unpack(msg) is not None:
            self.alarm_at = now()
            self.tick()

    def tick(self) -> None:
        if not self.clients:
            self.prepare()
        if self.alarm_at is None or self.switched_at is not None:
            return
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters
        binder = self.clients[""]
        if not binder.service_is_ready():
            return                  # the backup's protocol is not reachable yet: try again next tick
        for name in self.failed:    # fail-silent: a replica that is only slow must not answer too
            if self.clients[name].service_is_ready():
                self.calls.append(self.clients[name].call_async(ChangeState.Request(
                    transition=Transition(id=Transition.TRANSITION_DEACTIVATE))))
        params = [Parameter(name=f"reconf.port.{port}", value=ParameterValue(
            type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=conns))
            for port, conns in sorted(self.bindings.items())]
        self.calls.append(binder.call_async(SetParameters.Request(parameters=params)))
        self.switched_at = now()
        self.p.send("switch", {"takeover": self.backup})
        self.comp.node.get_logger().warning(
            f"alarm: {self.backup} takes over ({', '.join(f'{p} -> {c}' for p, c in sorted(self.bindings.items()))}), "
            f"{self.switched_at - self.alarm_at:.3f} s after the alarm")


def _layer(name: str) -> int:
    for i, layer in enumerate(("_sec_", "_dup_", "_tr_")):
        if layer in name:
            return i
    return 3
