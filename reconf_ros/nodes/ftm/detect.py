"""Crash detection and recovery of a duplex (paper 000 §5.2.2): the primary's crash detector
beats, the backup's raises an alarm when the beats stop, and Recovery makes the failed replica
fail-silent and binds the backup's outermost protocol to the proxy, through the control
interface (docs/control-interface.md), as a plan's attach does.

A primary that is only cut off from the others (a network partition) has not crashed: paper 000
assumes a failed replica fail-silent, so it must become so by itself. The backup's detector
answers each beat with a lease, the time the primary may go on serving from that beat's sending,
and promises not to take over before the lease it granted last has run out, with a margin for
the primary to fence itself; the primary's heartbeat, when its lease lapses while a backup's
detector is matched, deactivates every node of its replica (fail-silent) and beats no more
(docs/ftm.md#running)."""
from __future__ import annotations

import re
import time
from collections import OrderedDict, deque
from typing import Any, Optional

from reconf_dsl.ir import System

from ..api import Component
from .wire import Ports, now, unpack

__all__ = ["Heartbeat", "Detector", "Recovery", "MISSED_BEATS", "FENCE_MARGIN", "replica_nodes"]

MISSED_BEATS = 2.5      # intervals of silence before the backup's detector raises the alarm
MAX_PERIODS = 10.0      # the silence it waits for grows with the beats' jitter, up to this many periods
JITTER_WINDOW = 10.0    # s of beat intervals the jitter is read from
ARM_AFTER = 1.0         # s of regular beats before it does: a start-up hiccup is not a crash
CHECK_PERIOD = 0.05     # s between two looks at the silence
FENCE_MARGIN = 0.25     # s the backup waits beyond the lease it granted: the primary's time to fence itself
KEPT_BEATS = 200        # beats whose sending times the primary remembers (20 s at 10 Hz)


def replica_nodes(system: System, server: str, replica: int) -> list[str]:
    """The nodes of one replica of `server`'s mechanism, and its copy of the application."""
    prefix = f"{server}__r{replica}_"
    app = server if replica == 0 else f"{server}__r{replica}_app"
    return [c.name for c in system.components if c.name.startswith(prefix) and c.name != app] + [app]


def deactivate_clients(comp: Component, names: list[str]) -> dict[str, Any]:
    """ChangeState clients of `names`, made ahead of time: a request sent before its service is
    matched is lost."""
    from lifecycle_msgs.srv import ChangeState
    node = comp.node
    ns = node.get_namespace().rstrip("/")
    return {name: node.create_client(ChangeState, f"{ns}/{name}/change_state") for name in names}


def deactivate(clients: dict[str, Any]) -> list[Any]:
    """Ask every node whose service is there to deactivate (fail-silent); the calls' futures."""
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState
    return [cli.call_async(ChangeState.Request(transition=Transition(id=Transition.TRANSITION_DEACTIVATE)))
            for cli in clients.values() if cli.service_is_ready()]


class Heartbeat:
    """The primary's crash detector: beats at the model's rate (each beat numbered), holds the
    lease the backup's detector grants in answer (from the beat's sending), and fences its
    replica when the lease lapses while the backup's detector is matched: every node of the
    replica deactivated, no more beats, so the backup's alarm follows. A lease given back (the
    backup's detection suspended by a plan) or never given asks nothing: the primary serves."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p, self.comp = ports, comp
        rate = ports.fn.normal.guarantees.get("beat")
        self.period = 1.0 / float(rate.hz) if rate is not None and rate.hz else 0.1
        self.server = comp.name.split("__", 1)[0]
        self.replica = [n for n in replica_nodes(system, self.server, 0) if n != comp.name]
        self.n = 0
        self.sent: "OrderedDict[int, float]" = OrderedDict()     # beat -> when it was sent
        self.lease_until: Optional[float] = None
        self.fenced_at: Optional[float] = None
        self.fenced_wall = 0.0          # when, by the wall clock (the status says it)
        self.checked = now()
        self.clients: dict[str, Any] = {}
        comp.create_timer(1.0 / self.period, self.beat)
        comp.create_timer(1.0 / CHECK_PERIOD, self.check)
        ports.input("lease").on_message(self.on_grant)
        comp.report("lease", self.state)
        comp.report("fenced_at", lambda: f"{self.fenced_wall:.3f}" if self.fenced_at is not None else "")

    def state(self) -> str:
        """none (no lease asked), held (its end from now, s), fenced."""
        if self.fenced_at is not None:
            return "fenced"
        return "none" if self.lease_until is None else f"held {self.lease_until - now():+.3f}"

    def beat(self) -> None:
        if not self.clients:
            self.clients = deactivate_clients(self.comp, self.replica)
        if self.fenced_at is not None:
            return
        self.n += 1
        self.sent[self.n] = now()
        while len(self.sent) > KEPT_BEATS:
            self.sent.popitem(last=False)
        self.p.send("beat", {"beat": self.n})

    def on_grant(self, msg: Any) -> None:
        doc = unpack(msg, need="beat")
        if doc is None or self.fenced_at is not None:
            return
        grant = float(doc.get("grant") or 0.0)
        if grant <= 0:
            self.lease_until = None         # given back: the backup will not take over
            return
        sent = self.sent.get(int(doc["beat"]))
        if sent is not None:
            self.lease_until = max(self.lease_until or 0.0, sent + grant)

    def check(self) -> None:
        t, woke = now(), self.checked
        self.checked = t
        if t - woke > 2 * CHECK_PERIOD:
            return      # this process was stalled itself: grants queued meanwhile are read first
        if self.fenced_at is not None or self.lease_until is None or t <= self.lease_until:
            return
        node = self.comp.node
        if node is None or not self.p.normal or node.matched("lease") == 0:
            return      # no backup's detector there (a plan took it away): nobody will take over
        self.fence(t)

    def fence(self, t: float) -> None:
        """Fail-silent: every node of the replica deactivated, this one too, no more beats."""
        assert self.lease_until is not None
        self.fenced_at, self.fenced_wall = t, time.time()
        calls = deactivate(self.clients)
        self.comp.node.get_logger().warning(
            f"lease lapsed {t - self.lease_until:.3f} s ago: replica fenced (fail-silent), "
            f"{len(calls)} of {len(self.replica)} nodes asked to deactivate")
        self.comp.node.trigger_deactivate()


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
        self.promised = 0.0     # no takeover before this: the end of the last lease granted, and a margin
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
        self.grant(msg)

    def grant(self, msg: Any) -> None:
        """Answer a beat with a lease of the current silence limit (so the primary fences itself
        about when this detector would raise the alarm), or with none once suspended or alarmed;
        promise not to take over before its end and FENCE_MARGIN."""
        doc = unpack(msg, need="beat")
        if doc is None:
            return
        grant = self.limit if self.p.normal and self.alarmed_at is None else 0.0
        if grant > 0:
            self.promised = max(self.promised, now() + grant + FENCE_MARGIN)
        self.p.send("lease", {"beat": doc["beat"], "grant": round(grant, 3)})

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
        wait = max(0.0, self.promised - t)
        if silent > self.limit and self.p.send("alarm", {"failed": "r0", "silent_s": round(silent, 3),
                                                         "wait_s": round(wait, 3)}):
            self.alarmed_at = now()
            self.p.comp.node.get_logger().warning(f"no heartbeat for {silent:.3f} s: alarm raised")


class Recovery:
    """On the alarm, once the lease the backup's detector granted last has run out (the alarm
    says how long is left): deactivate replica 0's nodes that still answer (fail-silent), attach
    replica 1's outermost protocol where replica 0's was (the proxy's requests and replies), and
    tell it."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p, self.comp = ports, comp
        server = comp.name.split("__", 1)[0]
        prefix = f"{server}__"
        names = [c.name for c in system.components]
        r0 = sorted((n for n in names if re.fullmatch(rf"{re.escape(prefix)}r0_\w+_protocol", n)), key=_layer)
        self.failed = replica_nodes(system, server, 0)
        self.primary = r0[0] if r0 else ""
        self.backup = self.primary.replace("__r0_", "__r1_", 1)
        self.bindings: dict[str, list[str]] = {}
        for conn in system.connectors:
            for r in conn.roles:
                if r.component == self.primary and r.port in ("from_client", "reply"):
                    self.bindings.setdefault(r.port, []).append(conn.name)
        self.alarm_at: Optional[float] = None
        self.due: Optional[float] = None           # not before: the primary's lease and its fencing over
        self.switched_at: Optional[float] = None
        self.clients: dict[str, Any] = {}
        self.binder: Any = None
        self.calls: list[Any] = []
        ports.input("alarm").on_message(self.on_alarm)
        comp.create_timer(10, self.tick)

    def on_alarm(self, msg: Any) -> None:
        doc = unpack(msg)
        if self.alarm_at is None and self.p.normal and doc is not None:
            self.alarm_at = now()
            wait = max(0.0, float(doc.get("wait_s") or 0.0))
            self.due = self.alarm_at + wait
            if wait > 0:        # a timer of its own: the 10 Hz tick would add up to 0.1 s
                timer: Any = None

                def due() -> None:
                    self.comp.node.destroy_timer(timer)
                    self.tick()
                timer = self.comp.node.create_timer(wait, due)
            self.tick()

    def tick(self) -> None:
        if self.binder is None:
            from rcl_interfaces.srv import SetParameters
            self.clients = deactivate_clients(self.comp, self.failed)
            ns = self.comp.node.get_namespace().rstrip("/")
            self.binder = self.comp.node.create_client(SetParameters, f"{ns}/{self.backup}/set_parameters")
        if self.alarm_at is None or self.switched_at is not None or self.due is None or now() < self.due:
            return
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters
        if not self.binder.service_is_ready():
            return                  # the backup's protocol is not reachable yet: try again next tick
        self.calls += deactivate(self.clients)  # fail-silent: a replica that is only slow must not answer too
        params = [Parameter(name=f"reconf.port.{port}", value=ParameterValue(
            type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=conns))
            for port, conns in sorted(self.bindings.items())]
        self.calls.append(self.binder.call_async(SetParameters.Request(parameters=params)))
        self.switched_at = now()
        self.p.send("switch", {"takeover": self.backup})
        self.comp.node.get_logger().warning(
            f"alarm: {self.backup} takes over ({', '.join(f'{p} -> {c}' for p, c in sorted(self.bindings.items()))}), "
            f"{self.switched_at - self.alarm_at:.3f} s after the alarm "
            f"({self.due - self.alarm_at:.3f} s of it waiting out the primary's lease)")


def _layer(name: str) -> int:
    for i, layer in enumerate(("_sec_", "_dup_", "_tr_")):
        if layer in name:
            return i
    return 3
