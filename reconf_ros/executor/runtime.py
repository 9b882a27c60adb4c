"""The ROS side of the executor: lifecycle and parameter services of each component's node called
with retries, the graph and when it has settled, and the nodes' statuses on `/diagnostics`.

rclpy and the message packages are imported when a `Runtime` is made, not before: a plan script
replays its plan (`--dry-run`) without ROS."""
from __future__ import annotations

import os
import threading
import time
from typing import Any, Callable, Iterable, Optional

from .status import (
    ASK_DEPTH,
    ASK_TOPIC,
    STATUS_FRESH,
    STATUS_PREFIX,
    TOOL_PREFIX,
    Status,
    ask_text,
    parse_status,
    tool_node,
)

# A new participant learns of the running ones from their periodic announcements (Fast DDS
# answers a newcomer's own announcements with nothing sooner): every 3 s by default, every
# 0.25 s under reconf's loopback profile (docs/runtime.md#dds). So the graph is read after one
# period and a margin, counted from the start of discovery, and once it has been quiet.
FAST_DDS_ANNOUNCEMENT = 3.0     # s, Fast DDS's own leaseAnnouncement
DISCOVERY_MARGIN = 0.5
GRAPH_QUIET = 0.5       # s the set of nodes must stay unchanged (why 0.5: docs/executor.md#discovery)
ENDPOINTS_QUIET = 1.0   # s every topic's endpoint counts must stay unchanged too (reading them all)
ENDPOINTS_POLL = 0.1  # s between two counts of every topic's endpoints while discovery settles
RETRY_AFTER = 0.3     # s between two copies of an unanswered read-only call
# the lifecycle state each transition the executor asks for ends in
GOAL = {"configure": "inactive", "activate": "active", "deactivate": "inactive", "cleanup": "unconfigured",
        "shutdown": "finalized"}


def announcement_period(env: Optional[dict[str, str]] = None) -> float:
    """How often this environment's participants announce themselves: the leaseAnnouncement of
    the default participant profile in FASTDDS_DEFAULT_PROFILES_FILE, else Fast DDS's own."""
    import xml.etree.ElementTree as ET
    path = (os.environ if env is None else env).get("FASTDDS_DEFAULT_PROFILES_FILE", "")
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return FAST_DDS_ANNOUNCEMENT        # no profile (path ""), or one Fast DDS would not read either
    ns = "{http://www.eprosima.com}"
    default = root.find(f".//{ns}participant[@is_default_profile='true']")
    period = None if default is None else default.find(f".//{ns}leaseAnnouncement")
    if period is None:
        return FAST_DDS_ANNOUNCEMENT
    return float(period.findtext(f"{ns}sec") or 0) + float(period.findtext(f"{ns}nanosec") or 0) / 1e9


class StepFailed(Exception):
    """A step (or a read of the live system) could not be carried out; the message says why."""


class NoAnswer(StepFailed):
    """A service that was called gave no answer within the timeout (the request, or its answer,
    may have been lost on the way)."""


class NoControlInterface(StepFailed):
    """A node answered, but without the control interface's parameters: not a reconf node (nor an
    adapter), so there are no modes or attachments to read (docs/control-interface.md)."""


NOT_A_RECONF_NODE = ("a node not built with reconf is driven through an adapter: declare it in its component "
                     "(`node NAME { ... }`, docs/adapter.md)")


def one(answers: dict[str, Any], key: str) -> Any:
    """The answer for `key` of a call to many; its StepFailed raised."""
    answer = answers[key]
    if isinstance(answer, StepFailed):
        raise answer
    return answer


class Runtime:
    """The ROS side: lifecycle and parameter services of each component's node, the graph, and
    the nodes' statuses on /diagnostics."""

    def __init__(self, name: str, namespace: str, timeout: float, node_name: str = "",
                 executor: Optional[Callable[[], Any]] = None) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState, GetState
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import GetParameters, SetParameters
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        self.rclpy, self.Transition = rclpy, Transition
        self.ChangeState, self.GetState = ChangeState, GetState
        self.Parameter, self.ParameterType, self.ParameterValue = Parameter, ParameterType, ParameterValue
        self.GetParameters, self.SetParameters = GetParameters, SetParameters
        self.timeout = timeout
        # the steps of a batch run in threads of their own (docs/executor.md#batches): one spins
        # the node at a time, and a failed step halts the others at their next wait
        self.lock = threading.RLock()
        self.halt = threading.Event()
        ns = namespace.strip("/")
        self.namespace = f"/{ns}" if ns else ""
        self.deadline = float("inf")
        self.clients: dict[str, Any] = {}
        self.statuses: dict[str, Status] = {}             # node fqn -> its last status
        self.heard: dict[str, float] = {}                 # node fqn -> when its last status came
        from rclpy.signals import SignalHandlerOptions
        # rclpy's own handlers would shut the context down under a running step (RCLError,
        # ExternalShutdownException): SIGINT and SIGTERM are the run's (context.Interrupts)
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(node_name or tool_node(f"plan_{name}"), namespace=self.namespace or None)
        # one executor, the node added once: rclpy.spin_once(node) adds the node to the global
        # executor and removes it at every call, and each add wakes it once for nothing. A
        # long-lived runtime (the manager's) passes one that keeps its wait set (docs/executor.md#manager)
        from rclpy.executors import SingleThreadedExecutor
        self.executor = executor() if executor is not None else SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.started_at = time.monotonic()               # discovery began here
        self.discovery_round = announcement_period() + DISCOVERY_MARGIN
        self.graph_seen: set[str] = set()
        self.graph_since = self.started_at                # the graph last changed here
        self.endpoints_seen: Any = None                   # every topic's types and endpoint counts
        self.endpoints_at = 0.0                           # when they were last counted
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_status, qos)
        from std_msgs.msg import String
        self.String = String
        self.asker = self.node.create_publisher(String, ASK_TOPIC, QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=ASK_DEPTH, reliability=ReliabilityPolicy.RELIABLE))

    def close(self, exiting: bool = False) -> None:
        """Destroy the node and shut ROS down. `exiting` (the process ends next, a plan script's
        run): leave the node's entities to the deletion of its participant as the process exits,
        which others see at once all the same; destroying some seventy service clients one by one
        took 0.09-0.72 s beside a loaded system (docs/executor.md#discovery)."""
        self.executor.shutdown(timeout_sec=0)
        if exiting:
            self.node.context.untrack_node(self.node)
        else:
            self.node.destroy_node()
        try:
            self.rclpy.shutdown()
        except Exception:
            pass

    def _on_status(self, msg: Any) -> None:
        for st in msg.status:
            if st.name.startswith(STATUS_PREFIX):
                fqn = st.name[len(STATUS_PREFIX):]
                self.statuses[fqn] = parse_status(st.values)
                self.heard[fqn] = time.monotonic()

    def status(self, fqn: str) -> Optional[Status]:
        return self.statuses.get(fqn)

    def ask(self, since: float, inputs: Iterable[tuple[str, str]]) -> None:
        """Ask each (node fqn, input) for the status that shows it received after `since` (wall
        clock), rather than wait for its next periodic one (docs/control-interface.md#asked-status). An
        ask that reaches no one (not matched yet, lost) costs nothing but that wait."""
        with self.lock:
            self.asker.publish(self.String(data=ask_text(since, inputs)))

    def spin_once(self, seconds: float) -> None:
        """Spin the node once (for at most `seconds`), one thread at a time; a step of a batch
        another step of which failed stops here (StepFailed)."""
        if self.halt.is_set() and threading.current_thread() is not threading.main_thread():
            raise StepFailed("stopped: another step of its batch failed")
        with self.lock:
            self.executor.spin_once(timeout_sec=seconds)

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return
            self.spin_once(min(left, 0.02))

    def left(self) -> float:
        remaining = self.deadline - time.monotonic()
        if remaining <= 0:
            raise StepFailed("the step took longer than --step-timeout")
        return remaining

    def wait(self, cond: Callable[[], bool], seconds: float) -> bool:
        """Spin until `cond()` or `seconds` (and the step's deadline) pass."""
        end = min(time.monotonic() + seconds, self.deadline)
        while True:
            if cond():
                return True
            if time.monotonic() >= end:
                return False
            self.spin_once(0.01)

    def nodes(self) -> list[str]:
        """Nodes discovered in the graph, and nodes heard on /diagnostics (a reconf node publishes
        its status at least once a second, which discovery may not have caught up with)."""
        graph = [f"{ns.rstrip('/')}/{n}" for n, ns in self.node.get_node_names_and_namespaces()]
        now = time.monotonic()
        heard = {n for n, t in self.heard.items() if now - t <= STATUS_FRESH}
        return graph + sorted(heard - set(graph))

    def graph(self) -> set[str]:
        """The nodes now, noting when the set last changed (see `Executor.settle`): reconf's own
        hidden nodes (a tool's, a held process's) are never a component and do not count."""
        nodes = {n for n in self.nodes() if not n.rsplit("/", 1)[-1].startswith(TOOL_PREFIX)}
        if nodes != self.graph_seen:
            self.graph_seen, self.graph_since = nodes, time.monotonic()
        return nodes

    def settled(self, want: Callable[[set[str]], set[str]], endpoints: bool = False) -> bool:
        """Whether discovery has caught up (docs/executor.md#discovery): one announcement period
        and a margin since it began, the nodes `want(graph)` seen, and the graph unchanged for
        GRAPH_QUIET s. With `endpoints` (for reading them), every topic's publishers and
        subscribers unchanged too, for ENDPOINTS_QUIET s, and every node heard on /diagnostics in
        the graph itself."""
        nodes, now = self.graph(), time.monotonic()
        if endpoints:
            if now - self.endpoints_at < ENDPOINTS_POLL:
                return False
            self.endpoints_at = now
            sig = frozenset((t, tuple(ty), self.node.count_publishers(t), self.node.count_subscribers(t))
                            for t, ty in self.node.get_topic_names_and_types())
            shown = {f"{ns.rstrip('/')}/{n}" for n, ns in self.node.get_node_names_and_namespaces()}
            if sig != self.endpoints_seen or not nodes <= shown:
                self.endpoints_seen, self.graph_since = sig, now
        return want(nodes) <= nodes and now - self.started_at >= self.discovery_round and \
            now - self.graph_since >= (ENDPOINTS_QUIET if endpoints else GRAPH_QUIET)

    def client(self, srv_type: Any, name: str) -> Any:
        with self.lock:
            if name not in self.clients:
                self.clients[name] = self.node.create_client(srv_type, name)
            return self.clients[name]

    def forget(self, fqn: str) -> None:
        """Drop the clients of a node that is gone (a new node of that name needs new ones)."""
        with self.lock:
            for name in [n for n in self.clients if n.startswith(fqn + "/")]:
                self.node.destroy_client(self.clients.pop(name))

    def call(self, srv_type: Any, name: str, request: Any) -> Any:
        """One call that changes something, sent once (reads go through `call_many`)."""
        return one(self.call_many(srv_type, {name: request}, repeat=False), name)

    def call_many(self, srv_type: Any, requests: dict[str, Any], repeat: bool = True) -> dict[str, Any]:
        """Calls to many services of type `srv_type` at once (see `calls`)."""
        return self.calls({n: (srv_type, r) for n, r in requests.items()}, repeat)

    def calls(self, requests: dict[str, tuple[Any, Any]], repeat: bool = True) -> dict[str, Any]:
        """Calls to many services at once, each with its type: service name -> answer, or the
        StepFailed that explains why there is none within the timeout. A read-only call (`repeat`)
        is sent again every RETRY_AFTER s while unanswered, and the first answer to any of its copies is taken: a
        request that reaches a new service before the service has matched the caller is only
        delivered at the next DDS heartbeat, seconds later, and its answer can be lost the same
        way. A call that changes something is sent once."""
        answers: dict[str, Any] = {}
        clients = {n: self.client(srv_type, n) for n, (srv_type, _) in requests.items()}
        end = time.monotonic() + min(self.timeout, self.left())
        # each request goes as soon as its service is there: one service that never comes (a node
        # just gone) must not hold back the others until the time is up
        futs: dict[str, list[Any]] = {}
        sent: dict[str, float] = {}
        while time.monotonic() < end:
            t = time.monotonic()
            for n, cli in clients.items():
                if n not in futs and cli.service_is_ready():
                    futs[n], sent[n] = [cli.call_async(requests[n][1])], t
                elif repeat and n in futs and t - sent[n] >= RETRY_AFTER and not any(f.done() for f in futs[n]):
                    futs[n].append(cli.call_async(requests[n][1]))
                    sent[n] = t
            if len(futs) == len(clients) and all(any(f.done() for f in fs) for fs in futs.values()):
                break
            self.spin_once(0.01)
        for n in clients:
            if n not in futs:
                answers[n] = StepFailed(f"service {n} is not available")
        for n, fs in futs.items():
            first = next((f for f in fs if f.done()), None)
            for f in fs:
                if not f.done():
                    f.cancel()
                    clients[n].remove_pending_request(f)
            if first is None:
                answers[n] = NoAnswer(f"no answer from {n} within {self.timeout} s")
            elif first.exception() is not None:
                answers[n] = StepFailed(f"{n} failed: {first.exception()}")
            else:
                answers[n] = first.result()
        return answers

    def lifecycles(self, fqns: Iterable[str]) -> dict[str, Any]:
        """Lifecycle state labels of many nodes at once (a StepFailed where one did not answer). A
        node that serves its parameters and no lifecycle services is a NoControlInterface at once,
        not a timeout: it is not a reconf node."""
        return self.read({f: [] for f in fqns}, parameters=False)[0]

    def get_many(self, wanted: dict[str, list[str]]) -> dict[str, Any]:
        """Parameters of many nodes at once: fqn -> {name: value}, or a StepFailed."""
        return self._parameters(wanted, self.calls(self._asks(wanted)))

    def read(self, wanted: dict[str, list[str]], parameters: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
        """The lifecycle states (as `lifecycles`) and, with `parameters`, the parameters named (as
        `get_many`) of many nodes, every request sent at once: a reading is one round of calls, not
        two. A node's parameters are asked whatever its state; a caller reads them of an active one."""
        plain = {f for f in wanted if self.node.count_services(f"{f}/get_parameters")
                 and not self.node.count_services(f"{f}/get_state")}
        reqs = {f"{f}/get_state": (self.GetState, self.GetState.Request()) for f in wanted if f not in plain}
        if parameters:
            reqs.update(self._asks(wanted))
        res = self.calls(reqs)
        # the graph can show a node's parameter services before its lifecycle ones (discovery over
        # a lossy link): a node whose parameters answer as a reconf node's is asked its state
        late = {f for f in plain if parameters and self._declares(res[f"{f}/get_parameters"])}
        if late:
            res.update(self.calls({f"{f}/get_state": (self.GetState, self.GetState.Request()) for f in late}))
            plain -= late
        states: dict[str, Any] = {f: NoControlInterface(f"{f} serves no lifecycle services: {NOT_A_RECONF_NODE}")
                                  for f in plain}
        states.update({f: r if isinstance(r, StepFailed) else str(r.current_state.label)
                       for f, r in ((f, res[f"{f}/get_state"]) for f in wanted if f not in plain)})
        return states, (self._parameters(wanted, res) if parameters else {})

    def _declares(self, answer: Any) -> bool:
        """Whether a get_parameters answer has any of the parameters asked (a node that lacks one
        answers it unset, or leaves it out)."""
        return not isinstance(answer, StepFailed) and any(
            v.type != self.ParameterType.PARAMETER_NOT_SET for v in answer.values)

    def _asks(self, wanted: dict[str, list[str]]) -> dict[str, tuple[Any, Any]]:
        """The get_parameters call of each node of `wanted` (fqn -> names), as `calls` takes them."""
        asks = {}
        for fqn, names in wanted.items():
            req = self.GetParameters.Request()
            req.names = list(names)
            asks[f"{fqn}/get_parameters"] = (self.GetParameters, req)
        return asks

    def _parameters(self, wanted: dict[str, list[str]], res: dict[str, Any]) -> dict[str, Any]:
        """The answers `res` to get_parameters of `wanted` as values: fqn -> {name: value}, or a
        StepFailed."""
        out: dict[str, Any] = {}
        for fqn, names in wanted.items():
            r = res[f"{fqn}/get_parameters"]
            try:
                out[fqn] = r if isinstance(r, StepFailed) else self.values(fqn, names, r)
            except StepFailed as e:     # this node's answer, not the others'
                out[fqn] = e
        return out

    def lifecycle(self, fqn: str) -> str:
        """The node's lifecycle state, by label (`active`, `inactive`, …)."""
        return str(one(self.lifecycles([fqn]), fqn))

    def transition(self, fqn: str, transition_id: int, name: str) -> None:
        """Ask for a lifecycle transition, once (a second request would be refused, or worse). If
        no answer comes, the node's state is read: a transition done whose answer was lost (a
        lossy link) counts as done; otherwise the call's failure stands."""
        req = self.ChangeState.Request()
        req.transition.id = transition_id
        try:
            res = self.call(self.ChangeState, f"{fqn}/change_state", req)
        except NoAnswer:
            try:
                done = self.lifecycle(fqn) == GOAL[name]
            except StepFailed:
                done = False
            if not done:
                raise
            return
        if not res.success:
            raise StepFailed(f"{fqn} refused the lifecycle transition {name}")

    def get(self, fqn: str, names: list[str]) -> dict[str, Any]:
        return dict(one(self.get_many({fqn: names}), fqn))

    def values(self, fqn: str, names: list[str], res: Any) -> dict[str, Any]:
        """The answer to get_parameters(`names`) as values. A name without a value is not a value:
        rclpy answers a request naming an undeclared parameter with no value at all, rclcpp with
        NOT_SET; either way the node does not implement the control interface (NoControlInterface)."""
        missing = names[len(res.values):] if len(res.values) < len(names) else \
            [n for n, v in zip(names, res.values) if v.type == self.ParameterType.PARAMETER_NOT_SET]
        if missing:
            shown = ", ".join(missing[:3]) + (", …" if len(missing) > 3 else "")
            raise NoControlInterface(f"{fqn} does not implement the control interface: no value for {shown}; "
                                     f"{NOT_A_RECONF_NODE}")
        values: dict[str, Any] = {}
        for n, v in zip(names, res.values):
            if v.type == self.ParameterType.PARAMETER_STRING:
                values[n] = v.string_value
            elif v.type == self.ParameterType.PARAMETER_STRING_ARRAY:
                values[n] = sorted(v.string_array_value)
            else:
                raise StepFailed(f"{fqn} does not implement the control interface: parameter {n} is not "
                                 "declared as a string or a string array")
        return values

    def set(self, fqn: str, name: str, value: Any) -> None:
        pv = self.ParameterValue()
        if isinstance(value, str):
            pv.type, pv.string_value = self.ParameterType.PARAMETER_STRING, value
        else:
            pv.type, pv.string_array_value = self.ParameterType.PARAMETER_STRING_ARRAY, sorted(value)
        req = self.SetParameters.Request()
        req.parameters = [self.Parameter(name=name, value=pv)]
        # a value set again is the same value: sent again while unanswered, as a read is, since
        # a request or its answer lost on a lossy link would otherwise fail the step
        res = one(self.call_many(self.SetParameters, {f"{fqn}/set_parameters": req}), f"{fqn}/set_parameters")
        if not res.results or not res.results[0].successful:
            reason = res.results[0].reason if res.results else "no result"
            raise StepFailed(f"{fqn} refused {name}={value!r}: {reason}")
