"""A Component as an rclpy lifecycle node: the reference implementation of the control
interface (docs/control-interface.md), with the assumption monitor on every input.

Parameters `reconf.mode.<f>` and `reconf.port.<p>` are the desired state; a change is applied
before `set_parameters` answers. The node publishes its status on `/diagnostics`
(`diagnostic_msgs/DiagnosticArray`) whenever something in it changes and once a second.
"""
from __future__ import annotations

import functools
import gc
import json
import os
import select
import signal
import time
from collections import deque
from typing import Any, Callable, Optional, Sequence

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from ..executor.snapshot import MODEL_PARAM
from ..executor.status import ASK_DEPTH, ASK_SPAN, ASK_TOPIC, CREATED_ENV, STATUS_PREFIX, parse_ask, tool_node
from ..executor.steps import join_list
from .api import Component, DeclarationError, Functionality, Output, components_to_arch
from .kept_executor import KeptExecutor
from .monitor import GAP_FACTOR, Monitor

__all__ = ["ComponentNode", "run_components", "DATA_QOS", "STATUS_QOS"]

# Reliable with a deep history: messages published while a subscriber's callback is busy or
# its node is suspended are delivered when it resumes (docs/control-interface.md). Transient
# local: a publisher's messages from before a subscriber matched it (DDS matching takes up to
# seconds) are delivered on matching, so a make-before-break attach loses nothing.
DATA_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
# Requests on a service (`<connector>/request`) and data of a port that is not durable: reliable,
# never replayed to a late subscriber (a protocol attached during a transition must not run old
# requests again); what is sent before a match is lost, and the FTM proxy re-sends it. Deep
# enough for the queue a resumed protocol drains at once: a 20 s suspension at 50 requests/s is
# 1000 replies in a burst, and with a depth of 100 the client's reader lost 195 of them.
VOLATILE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5000, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
# An input's companion reader, made when a publisher on its connector offers volatile data (any
# node with the default QoS): a transient-local reader never matches one. What both readers
# deliver (a transient-local publisher's data) is taken once, by its publisher and sequence number.
HEARS_VOLATILE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                                durability=DurabilityPolicy.VOLATILE)
STATUS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
ASK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=ASK_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
# rclpy gives every publisher and subscription two event handlers of its own (incompatible QoS,
# incompatible type) unless told not to, and its executor walks each handler in Python at every
# wake-up (docs/runtime.md#cost). A node asks for the events it acts on, and its readers report
# both kinds of mismatch, so a writer needs none of its own.
NO_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
NO_READER_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)
MODES = ("normal", "degraded")
TICK_GRACE = 0.05   # seconds a timer tick may run late before it calls a silence a gap


class ComponentNode(LifecycleNode):
    """One component, one lifecycle node named after it: the control interface's node side.

    `ComponentNode(component, namespace=, gap_factor=, status_period=, deployed=, lean=)` needs
    `rclpy.init()` first (`run_components` does both). It makes the node `component.node_name`
    (else `component.name`) in `namespace`, sets `component.node` to itself, and declares, so that
    they can be read in every lifecycle state: `reconf.mode.<f>` (string) per functionality,
    `reconf.port.<p>` (string array) per port, and the read-only `reconf.model` (the component as
    `.arch` text; empty, with a warning, when the component cannot be printed). It starts
    unconfigured, every mode `degraded`, every port attached to nothing, and publishes its status
    on `/diagnostics` whenever it changes and every `status_period` seconds (1). `gap_factor` is
    the monitor's k (docs/runtime.md#the-assumption-monitor); `deployed` (port -> connectors)
    makes it attach so once active and turn each functionality normal as soon as its assumptions
    are met on the wire; `lean` serves only the control interface's four services
    (docs/runtime.md#cost).

    The control interface (docs/control-interface.md) goes through parameters: a set of
    `reconf.mode.*` or `reconf.port.*` is applied by `set_mode` or `set_attachments` before the
    answer, and refused with a reason, changing nothing, when the node is not active or the
    value is wrong. Called directly, those methods skip the lifecycle check and leave the
    parameters' values as they were. The node holds no lock: call its methods from callbacks of
    its own executor (the component's behaviours are such callbacks), not from another thread.
    """

    def __init__(self, component: Component, *, namespace: str = "", gap_factor: float = GAP_FACTOR,
                 status_period: float = 1.0, deployed: Optional[dict[str, list[str]]] = None,
                 lean: bool = False) -> None:
        # lean: only the four services the control interface uses (docs/runtime.md#cost); rclpy's
        # executor rebuilds its wait set from every entity at every wake-up
        super().__init__(component.node_name or component.name, namespace=namespace or None,
                         enable_communication_interface=not lean,
                         start_parameter_services=not lean)
        if lean:
            self._serve_control_interface()
        self.component = component
        component.node = self
        self.monitor = Monitor(component, gap_factor)
        self.active = False
        self.finished = False
        self.modes = {f.name: "degraded" for f in component.functionalities}
        self.attached: dict[str, list[str]] = {p.name: [] for p in component.ports}
        self.pubs: dict[tuple[str, str], Any] = {}
        self.subs: dict[tuple[str, str], Any] = {}
        self.companions: dict[tuple[str, str], Any] = {}     # an input's reader of volatile publishers
        self.matched_in: dict[tuple[str, str], list[int]] = {}   # publishers matched: [main reader, companion]
        self.raw = False           # True: subscriptions deliver serialized messages (an adapter relays them)
        self.matched_out: dict[tuple[str, str], int] = {}
        self.req_pubs: dict[tuple[str, str], Any] = {}    # a service client's requests
        self.req_subs: dict[tuple[str, str], Any] = {}    # a service server's requests
        self.app_timers: list[Any] = []
        self.held_requests: deque[tuple[str, Any]] = deque(maxlen=1000)
        self.mode_timers: dict[str, Any] = {}
        self.last: dict[str, Any] = {}
        self.published: dict[str, int] = {p.name: 0 for p in component.outputs}
        self.errors: list[str] = []
        self.gid_nodes: dict[bytes, str] = {}
        self.deployed = deployed        # attachments to make at start (see run_components)
        self.exit_status = 0            # the process's, once every node is finalized (run_components)
        self._internal = False
        self._declare_interface()
        self.add_on_set_parameters_callback(self._on_set)
        self.status_pub = self.create_publisher(DiagnosticArray, "/diagnostics", STATUS_QOS, event_callbacks=NO_EVENTS)
        # No polling: a silence timer per rated input, restarted by each arrival, fires only when
        # the input has been silent for its gap limit; changes are flushed through a guard
        # condition; the status is repeated at `status_period` (docs/runtime.md#cost).
        self.silence: dict[str, Any] = {}
        for i in component.inputs:
            limit = self.monitor.inputs[i.name].period_limit(gap_factor)
            if limit:
                self.silence[i.name] = self.create_timer(limit, self._tick)
        self.create_timer(status_period, self._repeat_status)
        # an executor waiting for an input to receive after a time asks for the status that shows it
        self.asked: dict[str, tuple[float, set[bytes]]] = {}   # input -> (since, publishers reported)
        self.create_subscription(String, ASK_TOPIC, self._on_ask, ASK_QOS, event_callbacks=NO_READER_EVENTS)
        self._dirty = False
        self._flush = self.create_guard_condition(self._tick)
        self._changed()

    def _declare_interface(self) -> None:
        """The control interface's parameters (docs/control-interface.md#parameters), and the model."""
        for f in self.component.functionalities:
            self.declare_parameter(f"reconf.mode.{f.name}", Parameter.Type.STRING,
                                   ParameterDescriptor(type=ParameterType.PARAMETER_STRING,
                                                       description=f"mode of {f.name}: normal or degraded"))
        for p in self.component.ports:
            # rclpy 9 types an empty list as BYTE_ARRAY: declare the type, then set the value.
            self.declare_parameter(f"reconf.port.{p.name}", Parameter.Type.STRING_ARRAY,
                                   ParameterDescriptor(type=ParameterType.PARAMETER_STRING_ARRAY,
                                                       description=f"connectors {p.name} is attached to"))
        # the component's model, read-only, for `reconf discover` (docs/control-interface.md#the-model)
        self.declare_parameter(MODEL_PARAM, self._model_text(),
                               ParameterDescriptor(type=ParameterType.PARAMETER_STRING, read_only=True,
                                                   description="the component as .arch text"))
        self._store_params()

    def _model_text(self) -> str:
        try:
            return components_to_arch([self.component])
        except DeclarationError as e:     # a model reconf cannot print: said, not guessed
            self.get_logger().warning(f"{MODEL_PARAM} left empty: {e}")
            return ""

    def _serve_control_interface(self) -> None:
        def get_state(req: Any, resp: Any) -> Any:
            resp.current_state.id, resp.current_state.label = self._state_machine.current_state
            return resp

        def change_state(req: Any, resp: Any) -> Any:
            # rclpy's own handler (rclpy is pinned, see pyproject.toml): transitions by id or label
            return self._LifecycleNodeMixin__on_change_state(req, resp)  # type: ignore[attr-defined]

        def get_parameters(req: Any, resp: Any) -> Any:
            resp.values = [self.get_parameter(n).get_parameter_value() for n in req.names if self.has_parameter(n)]
            return resp

        def set_parameters(req: Any, resp: Any) -> Any:
            resp.results = [self.set_parameters_atomically([Parameter.from_parameter_msg(p)]) for p in req.parameters]
            return resp

        for srv, name, cb in ((GetState, "get_state", get_state), (ChangeState, "change_state", change_state),
                              (GetParameters, "get_parameters", get_parameters),
                              (SetParameters, "set_parameters", set_parameters)):
            self.create_service(srv, f"~/{name}", cb)

    # --- parameters: the control interface ---
    def _store_params(self) -> None:
        self._internal = True
        try:
            self.set_parameters([Parameter(f"reconf.mode.{f}", Parameter.Type.STRING, m) for f, m in self.modes.items()]
                                + [Parameter(f"reconf.port.{p}", Parameter.Type.STRING_ARRAY, sorted(v))
                                   for p, v in self.attached.items()])
        finally:
            self._internal = False

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        if self._internal:
            return SetParametersResult(successful=True)
        for p in params:
            if not p.name.startswith("reconf."):
                continue
            why = self._apply(p)
            if why:
                self.get_logger().warning(f"refused {p.name}={p.value!r}: {why}")
                return SetParametersResult(successful=False, reason=why)
        return SetParametersResult(successful=True)

    def _apply(self, p: Parameter) -> Optional[str]:
        if p.name.count(".") < 2:
            return f"{p.name} is read-only"
        _, kind, name = p.name.split(".", 2)
        if not self.active:
            return f"{self.get_name()} is not active"
        if kind == "mode":
            if name not in self.modes:
                return f"no functionality {name}"
            if p.type_ != Parameter.Type.STRING or p.value not in MODES:
                return f"a mode is 'normal' or 'degraded', not {p.value!r}"
            return self.set_mode(name, p.value)
        if kind == "port":
            if name not in self.attached:
                return f"no port {name}"
            if p.type_ not in (Parameter.Type.STRING_ARRAY, Parameter.Type.BYTE_ARRAY) and p.value is not None:
                return "attachments are a string array"
            return self.set_attachments(name, list(p.value or []))
        return f"unknown parameter {p.name}"

    # --- modes ---
    def functionality(self, name: str) -> Functionality:
        """The component's functionality `name`; StopIteration when it has none of that name."""
        return next(f for f in self.component.functionalities if f.name == name)

    def set_mode(self, name: str, mode: str) -> Optional[str]:
        """Run functionality `name` in `mode` ("normal" or "degraded", not checked here: the
        parameter callback refuses anything else) from now on; returns why not if it cannot
        (None: done; an adapter's node may fail to apply a mode's actions to the node it drives).

        A mode with a callback and a rate gets a timer at that rate, replacing the previous mode's;
        a mode without a rate runs its callback on each message of its inputs; a mode without a
        callback runs nothing. `write` then publishes only what the new mode guarantees. Setting
        the mode a functionality is in already changes nothing (a timed mode whose timer is not
        running yet, as at activation, gets it). The status is marked changed. Any lifecycle
        state; the `reconf.mode.<name>` parameter is not updated (see the class docstring).
        StopIteration for an unknown functionality."""
        m = self.functionality(name).mode(mode)
        timed = m.rate is not None and m.callback is not None
        if self.modes[name] == mode and (name in self.mode_timers) == timed:
            return None     # already so (a first activation still starts a timed degraded mode)
        old = self.mode_timers.pop(name, None)
        if old is not None:
            self.destroy_timer(old)
        self.modes[name] = mode
        if timed:
            assert m.rate is not None and m.callback is not None
            self.mode_timers[name] = self.create_timer(1.0 / float(m.rate.hz), self._runner(name, m.callback))
        self.get_logger().info(f"{name} is {mode}")
        self._changed()
        return None

    def _runner(self, name: str, callback: Callable[..., Any]) -> Callable[[], None]:
        def run() -> None:
            try:
                callback()
            except Exception as e:   # a behaviour's fault must not take the control interface down
                self._fault(name, e)
        return run

    def _fault(self, name: str, e: Exception) -> None:
        self.errors.append(f"{name}: {type(e).__name__}: {e}")
        self.get_logger().error(f"{name} raised {type(e).__name__}: {e}")

    # --- attachments ---
    def set_attachments(self, port: str, wanted: list[str]) -> Optional[str]:
        """Attach `port` to exactly the connectors `wanted` (absolute topic names); None when done,
        else why not, with nothing changed.

        Refused: a name that is not an absolute topic name; a newly wanted topic that the graph
        shows carrying another type; a message type that is not installed. Otherwise the
        connectors no longer wanted lose their publisher or subscription (and a service port its
        request side) before the new ones get theirs: an output's publisher (a service's server
        subscribes to `<k>/request` first), an input's subscription (a service's client publishes
        on `<k>/request`), with the port's QoS (`DATA_QOS`, or `VOLATILE_QOS` when not durable).
        When it returns, the endpoints exist or are gone; matching with remote ones follows. Any
        lifecycle state; the `reconf.port.<port>` parameter is not updated (see the class
        docstring). DeclarationError for a port the component does not have."""
        p = self.component.port(port)
        bad = [k for k in wanted if not k.startswith("/") or "." in k or " " in k]
        if bad:
            return f"{', '.join(bad)}: not an absolute topic name"
        types = dict(self.get_topic_names_and_types())
        for k in wanted:
            if k not in self.attached[port] and k in types and p.msg_type not in types[k]:
                return f"{k} carries {', '.join(types[k])}, not {p.msg_type}"
        try:
            cls = p.message_class
        except (ImportError, AttributeError) as e:
            return f"message type {p.msg_type} is not installed ({e})"
        qos = DATA_QOS if p.durable else VOLATILE_QOS
        for k in sorted(set(self.attached[port]) - set(wanted)):
            if isinstance(p, Output):
                self.destroy_publisher(self.pubs.pop((port, k)))
                self.matched_out.pop((port, k), None)
                if (port, k) in self.req_subs:
                    self.destroy_subscription(self.req_subs.pop((port, k)))
            else:
                self.destroy_subscription(self.subs.pop((port, k)))
                if (port, k) in self.companions:
                    self.destroy_subscription(self.companions.pop((port, k)))
                self.matched_in.pop((port, k), None)
                self.monitor.inputs[port].publishers.pop(k, None)
                if (port, k) in self.req_pubs:
                    self.destroy_publisher(self.req_pubs.pop((port, k)))
        for k in sorted(set(wanted) - set(self.attached[port])):
            self._attach(p, k, cls, qos)
        self.attached[port] = sorted(set(wanted))
        self.get_logger().info(f"{port} attached to {self.attached[port] or 'nothing'}")
        self._changed()
        return None

    def _attach(self, p: Any, k: str, cls: Any, qos: QoSProfile) -> None:
        """Port `p`'s endpoints on connector `k` (set_attachments)."""
        port = p.name
        if isinstance(p, Output):
            if p.service:   # listen for requests before the replies' publisher is matched
                self.req_subs[(port, k)] = self.create_subscription(
                    cls, f"{k}/request", functools.partial(self._on_request, port), VOLATILE_QOS,
                    event_callbacks=self._mismatch_events((port, f"{k}/request")))
            self.matched_out[(port, k)] = 0
            on_out = functools.partial(self._matched_out, (port, k))
            self.pubs[(port, k)] = self.create_publisher(
                cls, k, qos, event_callbacks=PublisherEventCallbacks(matched=on_out, use_default_callbacks=False))
        else:
            self.monitor.inputs[port].publishers[k] = 0
            self.matched_in[(port, k)] = [0, 0]
            self.subs[(port, k)] = self._reader(port, k, qos, 0)
            if p.service:
                self.req_pubs[(port, k)] = self.create_publisher(cls, f"{k}/request", VOLATILE_QOS,
                                                                 event_callbacks=NO_EVENTS)

    def _reader(self, port: str, k: str, qos: QoSProfile, which: int) -> Any:
        """A subscription of input `port` on `k`: the main one (`which` 0) or its companion (1)."""
        p = self.component.port(port)
        events = self._mismatch_events((port, k), matched=functools.partial(self._matched_in, (port, k), which))
        return self.create_subscription(p.message_class, k, functools.partial(self._on_message, (port, k)), qos,
                                        event_callbacks=events, raw=self.raw)

    def _mismatch_events(self, key: tuple[str, str], matched: Optional[Callable[[Any], None]] = None
                         ) -> SubscriptionEventCallbacks:
        """A reader's events: `matched` if given, and both kinds of mismatch said in the log; none
        of rclpy's defaults besides (NO_EVENTS)."""
        return SubscriptionEventCallbacks(matched=matched, incompatible_qos=functools.partial(self._incompatible, key),
                                          incompatible_type=functools.partial(self._wrong_type, key),
                                          use_default_callbacks=False)

    def _wrong_type(self, key: tuple[str, str], info: Any) -> None:
        self.get_logger().warning(f"{key[0]} cannot hear a publisher on {key[1]}: it offers another message type")

    def _incompatible(self, key: tuple[str, str], info: Any) -> None:
        """A publisher on the connector that this input's reader cannot match: a companion reader
        hears one that offers volatile data; any other mismatch is said in the log."""
        if info.last_policy_kind == QoSPolicyKind.DURABILITY and key in self.subs and key not in self.companions:
            self.get_logger().info(f"{key[1]} has a publisher of volatile data: {key[0]} hears it too")
            self.companions[key] = self._reader(key[0], key[1], HEARS_VOLATILE_QOS, 1)
        elif info.last_policy_kind != QoSPolicyKind.DURABILITY:
            self.get_logger().warning(f"{key[0]} cannot hear a publisher on {key[1]}: it offers another "
                                      f"{QoSPolicyKind(info.last_policy_kind).name.lower()} (reconf reads reliable data)")

    def _matched_out(self, key: tuple[str, str], info: Any) -> None:
        if key in self.matched_out:
            self.matched_out[key] = info.current_count
            self._changed()

    def _matched_in(self, key: tuple[str, str], which: int, info: Any) -> None:
        pubs, counts = self.monitor.inputs[key[0]].publishers, self.matched_in.get(key)
        if key[1] in pubs and counts is not None:
            counts[which] = info.current_count
            pubs[key[1]] = max(counts)     # the companion matches every publisher the main reader does
            self._changed()

    def _source(self, topic: str, gid: bytes) -> str:
        node = self.gid_nodes.get(gid)
        if node is None:
            for e in self.get_publishers_info_by_topic(topic):
                if e.node_name.startswith("_NODE_NAME_UNKNOWN"):
                    continue    # the graph has the endpoint but not yet its node: ask again next time
                g = bytes(e.endpoint_gid)
                ns = e.node_namespace.rstrip("/")
                self.gid_nodes[g[:len(gid)]] = f"{ns}/{e.node_name}".lstrip("/")
            node = self.gid_nodes.get(gid, "?")
        return node

    def _on_message(self, key: tuple[str, str], msg: Any, info: Any) -> None:
        port, topic = key
        info = info if isinstance(info, dict) else {}
        received = info.get("received_timestamp")
        now = received / 1e9 if received else time.time()     # when the middleware received it
        gid = bytes(info.get("publisher_gid", {}).get("data", b""))
        seq = info.get("publication_sequence_number")
        if key in self.companions and self.monitor.duplicate(port, gid, seq):
            return              # both readers had it
        self._pass_on(port, msg)
        self._check(now)      # a gap that ends now is judged, exactly, before the message closes it
        fresh_before = self.monitor.fresh_sources(port, now)
        self.monitor.on_message(port, now, gid, seq, self._source(topic, gid))
        if port in self.silence:
            self.silence[port].reset()
        self.last[port] = msg
        if self.monitor.fresh_sources(port, now) != fresh_before or self._answers_ask(port, now, gid):
            self._changed()
        if self.active:
            for listener in self.component.port(port).listeners:  # type: ignore[attr-defined]
                try:
                    listener(msg)
                except Exception as e:
                    self._fault(port, e)
        for f in self.component.functionalities:
            m = f.mode(self.modes[f.name])
            if m.rate is None and m.callback is not None and any(i.name == port for i in f.inputs):
                try:
                    m.callback(msg)
                except Exception as e:
                    self._fault(f.name, e)

    def _pass_on(self, port: str, msg: Any) -> None:
        """Where a message goes before it is measured: nowhere here (an adapter hands it to its node)."""

    def _on_request(self, port: str, msg: Any) -> None:
        if not self.active:     # buffered, handed over on activation (docs/control-interface.md)
            self.held_requests.append((port, msg))
            return
        for handler in self.component.port(port).handlers:  # type: ignore[attr-defined]
            try:
                handler(msg)
            except Exception as e:
                self._fault(port, e)

    def send_request(self, port: str, msg: Any) -> bool:
        """Send a request on every service `port` (an input) is attached to."""
        if not self.active or not self.attached.get(port):
            return False
        self._publish(port, msg, self.req_pubs)
        return True

    def expect(self, port: str) -> None:
        """Note that one more message is owed on input `port`, asked for now: the monitor judges an
        on-demand input's rate only while something is owed (`Input.expect` calls this for
        on-demand inputs only). KeyError for a port that is not an input."""
        self.monitor.expect(port, time.time())

    def give_up(self, port: str) -> None:
        """Note that the oldest message owed on input `port` will not come (its asker gave the
        request up): the monitor stops waiting for it, and the status is marked changed. KeyError
        for a port that is not an input."""
        self.monitor.give_up(port)
        self._changed()

    def matched(self, port: str) -> int:
        """How many remote endpoints `port` is matched with now: subscribers of an output's
        topics, publishers of an input's."""
        if port in self.monitor.inputs:
            return sum(self.monitor.inputs[port].publishers.values())
        return sum(n for (q, _), n in self.matched_out.items() if q == port)

    def request_subscribers(self, port: str) -> int:
        """How many servers the requests of service input `port` reach now (matched)."""
        return sum(pub.get_subscription_count() for (q, _), pub in self.req_pubs.items() if q == port)

    def last_message(self, port: str) -> Any:
        """The last message input `port` received, from any of its connectors, in any mode or
        lifecycle state; None before the first (or for a port that is not an input)."""
        return self.last.get(port)

    def write(self, port: str, msg: Any) -> bool:
        """Publish on every connector `port` is attached to, if its functionality's current mode
        guarantees something there (a mode that guarantees nothing stays silent).

        True when published; False, publishing nothing, when the node is not active, the port is
        attached to nothing, or no functionality associated with it guarantees anything on it in
        its current mode. `msg` is a message of the port's type, or a value that becomes the
        `data` field of one (a type without `data` then raises)."""
        if not self.active or not self.attached.get(port):
            return False
        if not any(port in self.functionality(f).mode(m).guarantees for f, m in self.modes.items()
                   if any(o.name == port for o in self.functionality(f).outputs)):
            return False
        self._publish(port, msg, self.pubs)
        self.published[port] += 1
        return True

    def _publish(self, port: str, msg: Any, pubs: dict[tuple[str, str], Any]) -> None:
        """`msg` (or a message of the port's type with it as `data`) on each connector of `port`."""
        p = self.component.port(port)
        if not isinstance(msg, (p.message_class, bytes)):     # bytes: a serialized message, relayed as it is
            msg = p.message_class(data=msg)
        for k in self.attached[port]:
            pubs[(port, k)].publish(msg)

    # --- monitor and status ---
    def _on_ask(self, msg: Any) -> None:
        """An ask (docs/control-interface.md#asked-status) naming an input of this node: the node publishes
        its status at the first message on it from each publisher received after the ask's time."""
        since, inputs = parse_ask(msg.data)
        me = self.get_fully_qualified_name()
        for fqn, port in inputs:
            if fqn == me and port in self.monitor.inputs:
                self.asked[port] = (since, set())

    def _answers_ask(self, port: str, now: float, gid: bytes) -> bool:
        """Whether this message, received at `now`, is one an ask waits for (and note it is)."""
        asked = self.asked.get(port)
        if asked is None or now <= asked[0] or gid in asked[1]:
            return False
        if now - asked[0] > ASK_SPAN:
            del self.asked[port]
            return False
        asked[1].add(gid)
        return True

    def _tick(self) -> None:
        # a silence is judged with the timer's scheduling as grace
        self._check(time.time(), grace=TICK_GRACE)

    def _repeat_status(self) -> None:
        self._dirty = True
        self._check(time.time(), grace=TICK_GRACE)

    def _check(self, now: float, grace: float = 0.0) -> None:
        if self.monitor.check(now, self.modes if self.active else {}, self.attached, grace):
            self._changed()
        if self.deployed is not None and self.active:
            self._bring_up()
        if self._dirty:
            self.publish_status()

    def status_changed(self) -> None:
        """The component says its status has changed (`Component.changed`): published soon."""
        self._changed()

    def _changed(self) -> None:
        if not self._dirty:
            self._dirty = True
            self._flush.trigger()

    def status(self) -> dict[str, str]:
        """The node's status as it is now: the key-values of docs/control-interface.md#status-on-diagnostics
        (lifecycle, pid, modes, ports, the monitor's verdicts and counters, matched subscribers,
        messages published, `created` for a node a plan started, and the component's `app.*`
        reports). Any state; publishes nothing."""
        now = time.time()
        # finalized: the node stays in the graph while others of its process run (a new node of
        # its component then takes another name: docs/executor.md#names)
        lifecycle = "finalized" if self.finished else "active" if self.active else "inactive"
        out = {"component": self.component.name, "lifecycle": lifecycle,
               "pid": str(os.getpid()), "errors": str(len(self.errors))}
        if os.environ.get(CREATED_ENV):
            out["created"] = os.environ[CREATED_ENV]      # which plan's step started it (docs/executor.md#names)
        out.update({f"mode.{f}": m for f, m in self.modes.items()})
        out.update({f"port.{p}": join_list(v) for p, v in self.attached.items()})
        out.update(self.monitor.status(now))
        for (port, k), n in sorted(self.matched_out.items()):
            out[f"out.{port}@{k}.subscribers"] = str(n)
        for port, n in self.published.items():
            out[f"out.{port}.published"] = str(n)
        out.update({k: f() for k, f in self.component.reports.items()})
        return out

    def publish_status(self) -> None:
        """Publish `status()` on `/diagnostics` now, as one `DiagnosticStatus` named
        `reconf:<node fqn>`: ERROR while a functionality in its normal mode has an assumption not met
        on the wire, WARN after a behaviour raised, OK otherwise. The node also does this by itself on
        every change and every status period; calling it clears the pending change."""
        self._dirty = False
        values = self.status()
        st = DiagnosticStatus()
        st.name = f"{STATUS_PREFIX}{self.get_fully_qualified_name()}"
        st.hardware_id = self.component.name
        violating = sorted(self.monitor.violating)
        if violating:
            st.level, st.message = DiagnosticStatus.ERROR, "assumption not met in normal mode: " + ", ".join(
                f"{f} ({self.monitor.verdicts[f]})" for f in violating)
        elif self.errors:
            st.level, st.message = DiagnosticStatus.WARN, self.errors[-1]
        else:
            st.level, st.message = DiagnosticStatus.OK, "assumptions met" if self.active else "inactive"
        st.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [st]
        self.status_pub.publish(arr)

    # --- bring-up as deployed (reconf-node --deployed) ---
    def _bring_up(self) -> None:
        """Attach as deployed, then make each functionality normal once its assumptions are met
        on the wire; the node's own safe start, used before any plan runs."""
        assert self.deployed is not None
        changed = False
        for port, conns in list(self.deployed.items()):
            if sorted(conns) != self.attached[port]:
                why = self.set_attachments(port, conns)
                changed = True
                if why:
                    self.get_logger().error(f"cannot attach {port} as deployed: {why}")
                    self.deployed.pop(port)
        pending = [f for f, m in self.modes.items() if m == "degraded"]
        for f in pending:
            if not self.monitor.verdicts[f].startswith("not met"):
                self.set_mode(f, "normal")
                changed = True
        if not pending:
            self.deployed = None
        if changed:
            self._store_params()

    # --- lifecycle ---
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """unconfigured -> inactive: succeeds and does nothing; everything was declared at
        construction, so nothing new appears (docs/control-interface.md)."""
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """inactive -> active: the state the `create` action promises. Every functionality degraded
        (timed degraded modes start), every port attached to nothing and the parameters so; the
        component's own timers (`Component.create_timer`) start, and the service requests that
        arrived while inactive are handed to their handlers, in order. Then the node accepts
        mode and attachment changes. Succeeds."""
        self.active = True
        self._isolate()
        self.app_timers = [self.create_timer(1.0 / float(r.hz), self._runner("timer", cb))
                           for r, cb in self.component.timers]
        while self.held_requests:
            self._on_request(*self.held_requests.popleft())
        return TransitionCallbackReturn.SUCCESS

    def _stop_timers(self) -> None:
        for t in self.app_timers:
            self.destroy_timer(t)
        self.app_timers = []

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """active -> inactive: the component's timers stop, every functionality is degraded and
        every port detached (the parameters so), and the node refuses mode and attachment changes
        until it is active again; a service request that still reaches it is kept for the next
        activation. Succeeds."""
        self._stop_timers()
        self._isolate()
        self.active = False
        self._changed()
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """inactive -> unconfigured: succeeds and does nothing (the node is already isolated)."""
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Any primary state -> finalized: the component's timers stop, an active node isolates
        itself first, and the node is marked finished: `run_components` ends the process once
        every node it runs is finished and the answer has had time to go out. Succeeds."""
        self._stop_timers()
        if self.active:
            self._isolate()
            self.active = False
        self.finished = True   # the process exits once the answer is out (run_components)
        self._changed()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        """The node and its lifecycle state machine: rclpy's lifecycle node leaves the machine
        (and the services it holds) alive, and with it the node in the graph, answering nothing."""
        super().destroy_node()
        machine = getattr(self, "_state_machine", None)
        if machine is not None:
            machine.destroy_when_not_in_use()

    def _isolate(self) -> None:
        """Every functionality degraded, every port attached to nothing: the state `create` makes."""
        for f in self.modes:
            self.set_mode(f, "degraded")
        for p in self.attached:
            self.set_attachments(p, [])
        self._store_params()
        self._changed()


def wait_release(fd: int, components: Sequence[Component], stop: Optional[dict[str, bool]] = None) -> bool:
    """A held process's wait (docs/executor.md#held): True once the launcher releases it (a line on
    its pipe `fd`: the names its one component takes, "as" and "node", as `--as` and `--node` give
    them), False at the pipe's end (cancelled, or the launcher gone) or once `stop["now"]`."""
    try:
        got = b""
        while not (stop or {}).get("now") and not got.endswith(b"\n"):
            if select.select([fd], [], [], 0.1)[0]:
                more = os.read(fd, 4096)
                if not more:
                    return False
                got += more
        if not got.endswith(b"\n"):
            return False
    finally:
        os.close(fd)
    names = json.loads(got)
    for c in components[:1]:
        c.name = names.get("as", c.name)
        c.node_name = names.get("node", c.node_name)
    return True


def _held(fd: int, components: Sequence[Component], stop: dict[str, bool]) -> Optional[Any]:
    """Hold this process, its ROS context initialised, until the launcher releases it: a hidden
    node of reconf's own keeps its DDS participant up, so that discovery is done before the
    component's nodes exist. That node (to destroy once they do), or None when not released."""
    carrier = rclpy.create_node(tool_node("held"), enable_rosout=False, start_parameter_services=False,
                                use_global_arguments=False)
    if wait_release(fd, components, stop):
        return carrier
    carrier.destroy_node()
    return None


def run_components(components: Sequence[Component], *, args: Optional[list[str]] = None, namespace: str = "",
                   deployed: Optional[dict[str, dict[str, list[str]]]] = None, gap_factor: float = GAP_FACTOR,
                   linger: float = 0.5, lean: bool = False, hold: Optional[int] = None,
                   make_node: Callable[..., "ComponentNode"] = ComponentNode) -> int:
    """Run `components` in this process until every one is finalized (or SIGINT/SIGTERM); the
    highest of the nodes' `exit_status` (0 unless something failed under a node).

    With `deployed` (component -> port -> connectors), each node configures and activates
    itself, attaches as given and turns each functionality normal once its assumptions are met
    on the wire; otherwise nodes wait unconfigured for a plan's `create`. `make_node` makes
    each component's node (an adapter's for a component that is not a reconf node).

    Calls `rclpy.init(args=args)` (so once per process), makes one node per component
    (`lean` for all, or per component), spins them on one single-threaded executor, and replaces
    the SIGINT and SIGTERM handlers with ones that end the loop. Returns `linger` seconds after
    every node is finalized, or at a signal, having destroyed the nodes and shut rclpy down.
    With `hold` (a held process's pipe), makes them only once released (`_held`). Whatever
    `rclpy.init` or a node's construction raises is not caught."""
    rclpy.init(args=args)
    stop = {"now": False}

    def on_signal(signum: int, frame: Any) -> None:
        stop["now"] = True
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    executor = KeptExecutor()
    nodes: list[ComponentNode] = []
    carrier = None if hold is None else _held(hold, components, stop)
    if hold is not None and carrier is None:        # cancelled: it made no node
        rclpy.shutdown()
        return 0
    try:
        for c in components:
            node = make_node(c, namespace=namespace, gap_factor=gap_factor,
                             deployed=None if deployed is None else dict(deployed.get(c.name, {})), lean=lean or c.lean)
            executor.add_node(node)
            nodes.append(node)
            if deployed is not None:
                node.trigger_configure()
                node.trigger_activate()
        if carrier is not None:
            carrier.destroy_node()
        gc.collect()
        gc.freeze()     # what start-up made stays: a full collection walks only what came after it
        done_at: Optional[float] = None
        while not stop["now"]:
            executor.spin_once(timeout_sec=0.05)
            if done_at is None and all(n.finished for n in nodes):
                done_at = time.monotonic()
            if done_at is not None and time.monotonic() - done_at > linger:
                break
    finally:
        executor.shutdown(timeout_sec=0)    # lets go of the handles it keeps, so the nodes go at once
        for n in nodes:
            n.destroy_node()
        try:
            rclpy.shutdown()
        except Exception:
            pass
    return max((n.exit_status for n in nodes), default=0)

