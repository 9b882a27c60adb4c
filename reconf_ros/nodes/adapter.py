"""The adapter (docs/adapter.md): a ROS 2 node not built with reconf, plain or lifecycle, in any
language, driven through the control interface (docs/control-interface.md) on its behalf.

A component whose architecture says `node NAME [lifecycle] { ... }` runs as an `AdapterNode`:
a reconf lifecycle node named after the component, with the control interface's parameters,
its status and the assumption monitor, that starts the component's run line with the node
and its ports renamed to private names (`nodes.wrapped`) and

- relays each port between its private topic and exactly the connectors it is attached to,
  serialized (attach and detach make and destroy the connector's side before the answer);
- holds back, on each output, what the current mode guarantees nothing on;
- maps each mode onto the node as its `node` block says: lifecycle deactivate and activate,
  parameter values (system_modes' way), or holding alone;
- takes the node through create and remove: configure and activate, deactivate, cleanup and
  shutdown where it is a lifecycle node; SIGTERM, then SIGKILL, where it is not, and always
  at the end, so that no process is left behind;
- measures every input on the wire (the monitor of every reconf node) and what the node
  publishes on every output, and reports the node's process ending in its status, then
  shuts itself down: a component whose node died is gone, not normal.
"""
from __future__ import annotations

import gc
import signal
import sys
import threading
import time
from typing import Any, Optional, Sequence

from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter

from reconf_dsl.formatter import node_block
from reconf_dsl.ir import System

from .api import Component
from .component import ComponentNode, run_components
from .generic import from_architecture as model_of
from .wrapped import Wrapped, WrappedFailed, ros_namespace

__all__ = ["AdapterNode", "from_architecture", "run_nodes"]

WATCH_PERIOD = 0.2      # s between two looks at the node's process
RECHECK_PERIOD = 1.0    # s between two looks at the publishers of the node's outputs
SWITCH_INTERVAL = 0.001  # s a thread holds the interpreter while another waits (Python's default: 0.005)


def from_architecture(system: System, name: str) -> Component:
    """Component `name` of `system`, which has a `node` block: its model, no behaviour of its own
    (the node it drives behaves), and the block, which its `reconf.model` shows."""
    ir = system.component(name)
    if ir is None or ir.node is None:
        raise KeyError(f"{system.name} declares no component {name} with a `node` block")
    comp = model_of(system, name, behaviour=False)
    comp.wraps, comp.node_block = ir.node, node_block(ir.node)
    comp.lean = True          # the control interface's four services: a smaller wait set (docs/runtime.md#cost)
    return comp


def exit_text(code: int) -> str:
    """`status 3`, or `signal SIGKILL` for a process a signal ended."""
    if code < 0:
        try:
            return f"signal {signal.Signals(-code).name}"
        except ValueError:
            return f"signal {-code}"
    return f"status {code}"


class AdapterNode(ComponentNode):
    """The control interface of a node reconf does not build, implemented by relaying and driving it."""

    def __init__(self, component: Component, wrapped: Wrapped, **options: Any) -> None:
        self.lock = threading.Lock()          # the relays (the hidden node's thread) against changes
        super().__init__(component, **options)
        self.raw = True
        self.wrapped, self.spec = wrapped, wrapped.spec
        self.from_node = {p.name: 0 for p in component.outputs}
        self.held = {p.name: 0 for p in component.outputs}
        self.rate_mark = (time.monotonic(), dict(self.from_node))
        self.rates = {p.name: 0.0 for p in component.outputs}
        self.applied: dict[str, Any] = {}     # parameter -> the value last set on the node
        self.died: Optional[str] = None
        self.create_timer(WATCH_PERIOD, self._watch)
        # what start-up made (rclpy, the model, the language) is never garbage: a full collection
        # over it stalled the relays for tens of ms at 1 kHz (docs/adapter.md#what-it-costs)
        gc.collect()
        gc.freeze()
        # two threads relay (one each way): a waiting one gets the interpreter after 1 ms, not 5
        sys.setswitchinterval(SWITCH_INTERVAL)

    # --- relays ---
    def _pass_on(self, port: str, data: bytes) -> None:
        """A message of input `port`, as the connector delivered it: on to the node at once, then
        measured (the monitor times it by its reception)."""
        if self.active:
            self.wrapped.write(port, data)

    def _relay(self, port: str, data: bytes) -> None:
        """A message the node published on `port` (in the hidden node's thread): on to the port's
        connectors, unless the current mode guarantees nothing there."""
        with self.lock:
            self.from_node[port] += 1
            if not self.write(port, data) and self.active and self.attached.get(port):
                self.held[port] += 1

    def set_attachments(self, port: str, wanted: list[str]) -> Optional[str]:
        with self.lock:
            return super().set_attachments(port, wanted)

    # --- modes ---
    def set_mode(self, name: str, mode: str) -> Optional[str]:
        """The mode, then what it means for the node (`node` block); undone and refused if the node
        refuses it."""
        was = self.modes[name]
        with self.lock:
            super().set_mode(name, mode)
        why = self._drive()
        if why is not None and was != mode:
            with self.lock:
                super().set_mode(name, was)
            self._drive()
        return why

    def _drive(self) -> Optional[str]:
        """Bring the node to what the current modes say: a lifecycle node inactive while a
        functionality that deactivates it is degraded (or the adapter is not active), every
        parameter at its current mode's value. Deactivation first, activation last."""
        if self.died is not None:
            return self.died
        params = [(e.param, e.value) for f, m in self.modes.items() for e in self.spec.effects(f, m) if e.kind == "set"]
        active = self.active and not any(m == "degraded" and any(e.kind == "deactivate" for e in self.spec.effects(f, m))
                                         for f, m in self.modes.items())
        try:
            if self.spec.lifecycle and not active and self.wrapped.lifecycle == "active":
                self.wrapped.transition("deactivate")
            changed = [(n, v) for n, v in params if n not in self.applied or self.applied[n] != v]
            self.wrapped.set_parameters(changed)
            self.applied.update(changed)
            if self.spec.lifecycle and active and self.wrapped.lifecycle == "inactive":
                self.wrapped.transition("activate")
        except WrappedFailed as e:
            self._fault("node", e)
            return str(e)
        self._changed()
        return None

    def _apply(self, p: Parameter) -> Optional[str]:
        return self.died if self.died is not None else super()._apply(p)

    # --- create and remove ---
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Configure the node (a lifecycle node), then its private topics' relays."""
        try:
            if self.spec.lifecycle and self.wrapped.state() == "unconfigured":
                self.wrapped.transition("configure")
            comp = self.component
            self.wrapped.write_inputs({p.name: p.message_class for p in comp.inputs})
            outs = {p.name: p.message_class for p in comp.outputs}
            self.wrapped.read_outputs(outs, self._relay)
            self.wrapped.in_driver(lambda: self.wrapped.driver.create_timer(
                RECHECK_PERIOD, lambda: self.wrapped.recheck_outputs(outs, self._relay)))
        except WrappedFailed as e:
            self._fault("configure", e)
            return TransitionCallbackReturn.FAILURE
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        super().on_activate(state)
        return TransitionCallbackReturn.FAILURE if self._drive() else TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        super().on_deactivate(state)
        return TransitionCallbackReturn.FAILURE if self._drive() else TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            if self.spec.lifecycle and self.died is None and self.wrapped.state() == "inactive":
                self.wrapped.transition("cleanup")
        except WrappedFailed as e:
            self._fault("cleanup", e)
            return TransitionCallbackReturn.FAILURE
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Shut the node down (its lifecycle, where it has one), then end its process."""
        super().on_shutdown(state)
        if self.spec.lifecycle and self.died is None:
            try:
                self.wrapped.state()
                self.wrapped.transition("shutdown")
            except WrappedFailed as e:
                self.get_logger().warning(f"{e}; its process is ended all the same")
        self.wrapped.stopping = True
        code = self.wrapped.stop()
        self.get_logger().info(f"node {self.spec.name}'s process ended ({exit_text(code or 0)})")
        return TransitionCallbackReturn.SUCCESS

    # --- the node's process ---
    def _watch(self) -> None:
        """Notice the node's process ending unasked: say so in the status, refuse every change
        from then on, and shut down (a component whose node died is not there any more)."""
        code = self.wrapped.poll()
        if code is None or self.wrapped.stopping or self.died is not None:
            return
        self.died = f"node {self.spec.name}'s process ({self.wrapped.fqn}) exited with {exit_text(code)}"
        self._fault("node", RuntimeError(self.died))
        self.exit_status = 1
        self.publish_status()
        if self._state_machine.current_state[1] in ("unconfigured", "inactive", "active"):
            self.trigger_shutdown()
        self.finished = True

    def status(self) -> dict[str, str]:
        now = time.monotonic()
        out = super().status()         # the relays' thread only adds to counters: read without the lock
        counts = dict(self.from_node)
        since, before = self.rate_mark
        if now - since >= 0.5:
            self.rates = {p: (counts[p] - before[p]) / (now - since) for p in counts}
            self.rate_mark = (now, counts)
        code = self.wrapped.poll()
        pid = self.wrapped.proc.pid if self.wrapped.proc is not None else 0
        out.update({"node": self.wrapped.fqn, "node.pid": str(pid), "node.lifecycle": self.wrapped.lifecycle,
                    "node.process": "running" if code is None else f"exited with {exit_text(code)}"})
        for p, n in counts.items():
            out.update({f"out.{p}.from_node": str(n), f"out.{p}.held": str(self.held[p]),
                        f"out.{p}.node_rate_hz": f"{self.rates[p]:.2f}"})
        return out

    def destroy_node(self) -> None:
        self.wrapped.close()
        super().destroy_node()


def run_nodes(components: Sequence[Component], *, args: Optional[list[str]] = None, **options: Any) -> int:
    """`run_components`, where a component with a `node` block runs as an adapter: its node's
    process is started first (before rclpy.init, as a process with DDS threads must not fork)
    and is up before the adapter's node is made, so that a plan's create finds it there."""
    ros_args = list(args or [])
    namespace = ros_namespace(ros_args)
    wrapped = {c.name: Wrapped(c.run or "", c.wraps, c.node_name or c.name, namespace)
               for c in components if c.wraps is not None}

    def make(c: Component, **kw: Any) -> ComponentNode:
        if c.name not in wrapped:
            return ComponentNode(c, **kw)
        w = wrapped[c.name]
        w.connect()
        w.wait_up()
        return AdapterNode(c, w, **kw)
    try:
        for w in wrapped.values():
            w.start()
        return run_components(components, args=args, make_node=make, **options)
    except (WrappedFailed, OSError) as e:
        print(f"reconf adapter: {e}", file=sys.stderr, flush=True)
        return 1
    finally:
        for w in wrapped.values():
            w.close()
