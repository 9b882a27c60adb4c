"""A snapshot of the live ROS 2 graph as plain data, for `reconf discover` and `reconf drift`
(docs/control-interface.md#the-model): nodes, their topics and services, lifecycle states, and
for reconf nodes their model (`reconf.model`), modes and attachments.

ROS is imported only inside `read_snapshot`, through the executor's `Runtime` (its retries, its
status reader); `Snapshot` itself is plain data that `checker.reality.drift` compares without ROS.
Which modes and attachments a reconf node has is read from its model text by the caller's
`ModelNames` (the checker parses it; this module, like the rest of the executor, is standard
library only).
"""
from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable, Optional

from .runtime import NoControlInterface, Runtime, StepFailed
from .status import STATUS_FRESH, find_node, tool_node

__all__ = ["MODEL_PARAM", "ModelNames", "NodeInfo", "RosUnavailable", "Snapshot", "read_snapshot"]

MODEL_PARAM = "reconf.model"     # a reconf node's component as .arch text (read-only string)
# the middleware's and reconf's own topics, not the application's
HIDDEN_TOPICS = frozenset({"/rosout", "/parameter_events", "/diagnostics"})
HIDDEN_SUFFIXES = ("/transition_event",)
# services every node (or every lifecycle node) has: neither a server nor a client of one is the
# application's (a tool asking /talker/get_parameters is not a part of the system)
STANDARD_SERVICES = frozenset({"describe_parameters", "get_parameter_types", "get_parameters", "list_parameters",
                     "set_parameters", "set_parameters_atomically", "get_state", "change_state",
                     "get_available_states", "get_available_transitions", "get_transition_graph",
                     "get_type_description"})

Progress = Callable[[str], None]
ModelNames = Callable[[str], tuple[list[str], list[str]]]   # model text -> (functionalities, ports)


class RosUnavailable(Exception):
    """rclpy cannot be imported or started here."""


@dataclass
class NodeInfo:
    """One node: its application endpoints (topic or service -> types), and what a reconf node
    tells of itself."""

    fqn: str
    publishers: dict[str, list[str]] = field(default_factory=dict)
    subscribers: dict[str, list[str]] = field(default_factory=dict)
    servers: dict[str, list[str]] = field(default_factory=dict)
    clients: dict[str, list[str]] = field(default_factory=dict)
    lifecycle: Optional[str] = None      # `active`, `inactive`, ..., `unresponsive`; None: not a lifecycle node
    model: Optional[str] = None          # the reconf.model text; None: not a reconf node
    component: Optional[str] = None      # the component the node declares (its status), if it does
    modes: dict[str, str] = field(default_factory=dict)
    ports: dict[str, list[str]] = field(default_factory=dict)
    pid: Optional[int] = None
    unanswered: str = ""                 # why a read of the node got no answer ("": every read was answered)
    created: Optional[str] = None        # the mark of the plan step that started it (docs/executor.md#names)

    @property
    def name(self) -> str:
        return self.fqn.rsplit("/", 1)[1]

    @property
    def namespace(self) -> str:
        return self.fqn.rsplit("/", 1)[0]

    @property
    def has_endpoints(self) -> bool:
        return bool(self.publishers or self.subscribers or self.servers or self.clients)


@dataclass
class Snapshot:
    """The live system in one namespace: its nodes by fully qualified name, every topic's types."""

    nodes: dict[str, NodeInfo] = field(default_factory=dict)
    topics: dict[str, list[str]] = field(default_factory=dict)
    namespace: str = ""
    settled: bool = True
    seconds: float = 0.0           # the whole reading, from the start of discovery (after rclpy.init)
    settle_seconds: float = 0.0    # of which waiting for discovery to settle

    def publishers(self, topic: str) -> list[str]:
        return sorted(n.fqn for n in self.nodes.values() if topic in n.publishers)

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1, sort_keys=True)

    @staticmethod
    def from_json(text: str) -> "Snapshot":
        """A snapshot saved by `to_json`; ValueError, saying what is wrong, for anything else."""
        doc = json.loads(text)
        if not isinstance(doc, dict) or not isinstance(doc.get("nodes"), dict) or \
                not all(isinstance(v, dict) for v in doc["nodes"].values()):
            raise ValueError("not a snapshot (a JSON object with `nodes`, as --save-snapshot writes)")
        try:
            nodes = {k: NodeInfo(**v) for k, v in doc.pop("nodes").items()}
            return Snapshot(nodes=nodes, **doc)
        except TypeError as e:     # a field that is not a snapshot's
            raise ValueError(f"not a snapshot as --save-snapshot writes: {e}") from None


def hidden_topic(name: str) -> bool:
    return name in HIDDEN_TOPICS or name.endswith(HIDDEN_SUFFIXES)


def _application(services: dict[str, list[str]]) -> dict[str, list[str]]:
    """The services that are not every node's (any node's: clients of another's count too)."""
    return {s: t for s, t in services.items() if s.rsplit("/", 1)[1] not in STANDARD_SERVICES}


def read_snapshot(model_names: ModelNames, namespace: str = "", settle: float = 10.0, timeout: float = 5.0,
                  progress: Progress = lambda _: None, expect: frozenset[str] = frozenset()) -> Snapshot:
    """Wait for the graph to settle (bounded by `settle` s; the nodes of the components `expect`ed
    seen too, as the executor waits for a plan's), then read every node of `namespace`; a reconf
    node's modes and attachments are the ones `model_names` finds in its model text.
    Raises RosUnavailable when rclpy is not installed or does not start."""
    import importlib.util
    if importlib.util.find_spec("rclpy") is None:
        raise RosUnavailable("rclpy is not installed: pip install 'reconf[ros]'")
    try:
        rt = Runtime("discover", namespace, timeout, node_name=tool_node("discover"))
    except Exception as e:       # rclpy.init() or the node: the middleware did not start
        raise RosUnavailable(f"ROS 2 did not start: {type(e).__name__}: {e}") from None
    t0 = rt.started_at        # rclpy.init() and the node are not part of the reading
    try:
        progress(f"waiting for discovery to settle (at most {settle:g} s)…")
        settled = _settle(rt, settle, expect)
        t1 = time.monotonic()
        snap = _read(rt, progress, model_names)
        snap.settled, snap.seconds, snap.settle_seconds = settled, time.monotonic() - t0, t1 - t0
        return snap
    finally:
        rt.close()


def _settle(rt: Any, seconds: float, expect: frozenset[str]) -> bool:
    """The executor's rule (`Runtime.settled`, docs/executor.md#discovery), endpoints included, each
    expected component's node found as the executor finds it (`find_node`); or `seconds`."""

    def want(nodes: set[str]) -> set[str]:
        own = {c: f"{rt.namespace}/{c}" for c in expect}
        return {find_node(fqn, c, nodes, rt.statuses) or fqn for c, fqn in own.items()}
    return bool(rt.wait(lambda: rt.settled(want, endpoints=True), seconds))


def _endpoints(pairs: Any) -> dict[str, list[str]]:
    return {name: sorted(types) for name, types in pairs if not hidden_topic(name)}


def _read(rt: Any, progress: Progress, model_names: ModelNames) -> Snapshot:
    node, ns = rt.node, rt.namespace or ""
    own = node.get_fully_qualified_name()
    snap = Snapshot(namespace=ns)
    snap.topics = _endpoints(node.get_topic_names_and_types())
    for name, node_ns in node.get_node_names_and_namespaces():
        fqn = f"{node_ns.rstrip('/')}/{name}"
        if fqn == own or node_ns.rstrip("/") != ns or name.startswith("_"):
            continue
        info = NodeInfo(fqn)
        try:
            info.publishers = _endpoints(node.get_publisher_names_and_types_by_node(name, node_ns))
            info.subscribers = _endpoints(node.get_subscriber_names_and_types_by_node(name, node_ns))
            servers = _endpoints(node.get_service_names_and_types_by_node(name, node_ns))
            info.clients = _application(_endpoints(node.get_client_names_and_types_by_node(name, node_ns)))
        except Exception:     # the node left between the two reads
            continue
        info.servers = _application(servers)
        if f"{fqn}/get_state" in servers:
            info.lifecycle = "unresponsive"
        snap.nodes[fqn] = info
        info.model = "" if f"{fqn}/get_parameters" in servers else None    # asked below
    progress(f"reading {len(snap.nodes)} node{'' if len(snap.nodes) == 1 else 's'}…")
    _read_reconf(rt, snap, model_names)
    return snap


def _read_reconf(rt: Runtime, snap: Snapshot, model_names: ModelNames) -> None:
    """Lifecycle states, models, then the reconf nodes' modes and attachments, each all at once.
    A node's lifecycle state is the one its own status last said, when that status is fresh (it
    publishes one on every change and each second: docs/control-interface.md#status-on-diagnostics), and is
    asked by get_state otherwise: at 100 nodes a round of get_state calls took 1.5-3 s. A node
    that does not answer is marked so."""
    now = time.monotonic()
    said = {f: st["lifecycle"] for f, st in rt.statuses.items()
            if f in snap.nodes and "lifecycle" in st and now - rt.heard.get(f, 0.0) <= STATUS_FRESH}
    states: dict[str, Any] = dict(said)
    states.update(rt.lifecycles([f for f, n in snap.nodes.items() if n.lifecycle and f not in said]))
    for fqn, label in states.items():
        snap.nodes[fqn].lifecycle = "unresponsive" if isinstance(label, StepFailed) else label
        if isinstance(label, StepFailed):
            snap.nodes[fqn].unanswered = f"get_state: {label}"
    models = rt.get_many({f: [MODEL_PARAM] for f, n in snap.nodes.items() if n.model is not None})
    wanted: dict[str, list[str]] = {}
    for fqn, values in models.items():
        info = snap.nodes[fqn]
        if isinstance(values, NoControlInterface):   # it answered: no model, so not a reconf node
            info.model = None
            continue
        if isinstance(values, StepFailed):       # a reconf node or not: nobody can say
            info.model, info.unanswered = None, info.unanswered or f"{MODEL_PARAM}: {values}"
            continue
        info.model = values.get(MODEL_PARAM) or None
        if info.model:
            funcs, ports = model_names(info.model)
            wanted[fqn] = [f"reconf.mode.{f}" for f in funcs] + [f"reconf.port.{p}" for p in ports]
        status = rt.status(fqn) or {}
        info.component = status.get("component")
        info.pid = int(status["pid"]) if status.get("pid", "").isdigit() else None
        info.created = status.get("created") or None
    for fqn, values in rt.get_many(wanted).items():
        info = snap.nodes[fqn]
        if isinstance(values, StepFailed):
            info.unanswered = info.unanswered or f"reconf.mode.*, reconf.port.*: {values}"
            continue
        info.modes = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.mode.")}
        info.ports = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.port.")}
