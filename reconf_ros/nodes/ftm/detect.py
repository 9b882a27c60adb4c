"""Crash detection and recovery of a duplex (paper 000 §5.2.2): the primary's crash detector
beats, the backup's raises an alarm when the beats stop, and Recovery makes the failed replica
fail-silent and binds the backup's outermost protocol to the proxy, through the control
interface (docs/control-interface.md), as a plan's attach does. The primary's detector is the
model-driven publisher of its beats (reconf_ros.nodes.ftm.BEHAVIOURS)."""
from __future__ import annotations

import re
from collections import deque
from typing import Any, Optional

from reconf_dsl.ir import System

from ..api import Component
from .wire import Ports, now, unpack

__all__ = ["Detector", "Recovery", "MISSED_BEATS"]

MISSED_BEATS = 2.5      # intervals of silence before the backup's detector raises the alarm
MAX_PERIODS = 10.0      # the silence it waits for grows with the beats' jitter, up to this many periods
JITTER_WINDOW = 10.0    # s of beat intervals the jitter is read from
ARM_AFTER = 1.0         # s of regular beats before it does: a start-up hiccup is not a crash
CHECK_PERIOD = 0.05     # s between two looks at the silence


class Detector:
    """Raises one alarm when the primary's beats stop for MISSED_BEATS of the longest intervals
    between beats of the last JITTER_WINDOW seconds (at least MISSED_BEATS periods, at most
    MAX_PERIODS; the most until the beats have come for JITTER_WINDOW seconds), once they have
    come regularly for ARM_AFTER seconds. Silence counts only while its own process runs. A
    loaded host beats late now and then: the silence that means a crash there is longer than on
    an idle one (docs/ftm.md, crash detection)."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        hz = ports.input("beat").assumption.hz
        self.period = 1.0 / float(hz) if hz else 0.1
        self.limit = MAX_PERIODS * self.period
        self.last: Optional[float] = None
        self.gaps: deque[tuple[float, float]] = deque()     # (when, interval) of recent beats
        self.steady_since: Optional[float] = None    # regular beats since then
        self.alarmed_at: Optional[float] = None
        self.checked = now()
        ports.input("beat").on_message(self.on_beat)
        comp.create_timer(1.0 / CHECK_PERIOD, self.check)
        comp.report("silence_limit_s", lambda: f"{self.limit:.3f}")
        comp.report("detector", self.state)

    def on_beat(self, msg: Any) -> None:
        t = now()
        if self.last is None or t - self.last > self.limit:
            self.steady_since = t
        if self.last is not None:
            self.gaps.append((t, t - self.last))
            while self.gaps and self.gaps[0][0] < t - JITTER_WINDOW:
                self.gaps.popleft()
            if self.steady_since is not None and t - self.steady_since >= JITTER_WINDOW:
                longest = max(g for _, g in self.gaps)
                self.limit = min(MAX_PERIODS * self.period, MISSED_BEATS * max(self.period, longest))
            else:       # too few beats yet to know the jitter: the longest wait
                self.limit = MAX_PERIODS * self.period
        self.last = t

    def state(self) -> str:
        """waiting (no beat yet), learning (beats for less than JITTER_WINDOW s), armed, alarmed."""
        if self.alarmed_at is not None:
            return "alarmed"
        if self.last is None or self.steady_since is None:
            return "waiting"
        return "armed" if self.last - self.steady_since >= JITTER_WINDOW else "learning"

    def check(self) -> None:
        t, woke = now(), self.checked
        self.checked = t
        if t - woke > 2 * CHECK_PERIOD:
            return      # this process was stalled itself: beats queued meanwhile are read first
        if self.alarmed_at is not None or self.last is None or self.steady_since is None or not self.p.normal:
            return
        if self.last - self.steady_since < ARM_AFTER:
            return
        silent = t - self.last
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
