#!/usr/bin/env python3
"""Reconfiguration plan for the ROS 2 system chatter: 5 steps, strategy default.

Architecture fingerprint: sha256:031278264f8066602fcba333e91cc6f82459189e5ae0477d78be2d543c022981

    python3 this_file.py --dry-run     replay the plan against the embedded model (no ROS needed)
    python3 this_file.py               apply the plan to the running system (needs rclpy)

Options: --yes (no confirmation prompt), --from-step N (resume at step N), --timeout S (per
service call), --step-timeout S (per step), --wire-timeout S (wait for matching and data),
--namespace NS (of the components' nodes), --log-dir DIR (output of started processes),
--report FILE (the run's report, JSON), --stop-started (on failure, stop what this run started).
Exit status: 0 every step done and the wire showed no violated assumption (or, with --dry-run,
every state safe); 1 a state is unsafe, the live system does not match the plan, a step failed,
or the monitors saw a violated assumption; 2 bad usage or ROS 2 not available.

Each component runs one lifecycle node named after it that implements the reconf control
interface (docs/control-interface.md). The executor below is reconf_ros/executor.py, embedded
as it is (docs/executor.md); the plan is the JSON document at the end.

Generated from the plan below; edit the plan, not this file.
"""
from __future__ import annotations

import argparse
import datetime
import functools
import hashlib
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from fractions import Fraction
from typing import Any, Callable, Iterable, Iterator, Optional

SYMBOLS = {"create": "+", "remove": "-", "attach": "\u2192", "detach": "\u00d7", "degrade": "\u2193",
           "upgrade": "\u2191"}
STATUS_PREFIX = "reconf:"
CREATED_ENV = "RECONF_CREATED"     # "<model fingerprint> <component>", given to the processes a plan starts
# Fast DDS announces each participant every 3 s. A participant that starts seconds after
# another on the same host stopped saw the running nodes only after 1.1-3.7 s in 12 of 16 tries
# (docs/executor.md#manager). So the graph is read after one period and a margin, counted from
# the start of discovery, and once it has been quiet.
DISCOVERY_ROUND = 3.5
GRAPH_QUIET = 1.0
STATUS_FRESH = 2.5    # s a status counts as a sign of life (nodes repeat theirs every second)
ENDPOINTS_POLL = 0.1  # s between two counts of every topic's endpoints while discovery settles
TOOL_PREFIX = "_reconf_"    # reconf's own nodes: hidden (a leading underscore), never a component
RETRY_AFTER = 0.3     # s between two copies of an unanswered read-only call
EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def join_list(items: Iterable[str]) -> str:
    return ",".join(sorted(items))


def plural(n: int, word: str, many: str = "") -> str:
    """A count and its noun in agreement: `1 step`, `3 steps`."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


def split_list(text: str) -> list[str]:
    return [x for x in text.split(",") if x]


def parse_status(values: Iterable[Any]) -> dict[str, str]:
    """A DiagnosticStatus's key-values as a dict (the keys are in docs/control-interface.md)."""
    return {kv.key: kv.value for kv in values}


# --- the model: satisfaction exactly as DESIGN.md section 3 states it ----------------------

class State:
    """A configuration: present components, degraded (component, functionality), roles
    (connector, component, port)."""

    def __init__(self, components: Iterable[str], degraded: Iterable[Any], roles: Iterable[Any]) -> None:
        # frozensets are taken as they are (a state derived from another shares its unchanged parts)
        self.components = components if isinstance(components, frozenset) else frozenset(components)
        self.degraded = degraded if isinstance(degraded, frozenset) else frozenset((d[0], d[1]) for d in degraded)
        self.roles = roles if isinstance(roles, frozenset) else frozenset((r[0], r[1], r[2]) for r in roles)

    @staticmethod
    def from_doc(d: dict[str, Any]) -> "State":
        return State(d["components"], d["degraded"], d["roles"])

    def changed(self, change: dict[str, Any]) -> "State":
        """This state with a plan document's change of one step applied (format 2: `add`, `drop`)."""
        parts: list[frozenset[Any]] = []
        for key, now in zip(("components", "degraded", "roles"), self.key()):
            add, drop = ({x if isinstance(x, str) else tuple(x) for x in change.get(side, {}).get(key, ())}
                         for side in ("add", "drop"))
            parts.append((now - drop) | add if add or drop else now)
        return State(parts[0], parts[1], parts[2])

    def to_doc(self) -> dict[str, Any]:
        return {"components": sorted(self.components), "degraded": [list(d) for d in sorted(self.degraded)],
                "roles": [list(r) for r in sorted(self.roles)]}

    def key(self) -> tuple[frozenset[str], frozenset[tuple[str, str]], frozenset[tuple[str, str, str]]]:
        return (self.components, self.degraded, self.roles)

    def only(self, comps: Iterable[str]) -> "State":
        keep = set(comps)
        return State(self.components & keep, [d for d in self.degraded if d[0] in keep],
                     [r for r in self.roles if r[1] in keep])

    def describe(self) -> str:
        comps = ", ".join(sorted(self.components)) or "-"
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(self.degraded) if c in self.components) or "-"
        roles = ", ".join(f"{c}.{p}@{n}" for n, c, p in sorted(self.roles)) or "-"
        return f"components: {comps}\n    degraded: {degraded}\n    attachments: {roles}"


class PlanStates:
    """The states of a plan document's plan: from its first state and each step's change
    (format 2), one state in 64 kept and the others replayed, so a plan of n steps on m
    components does not take n·m in memory; or every state as recorded (format 1)."""

    EVERY = 64

    def __init__(self, plan: dict[str, Any]) -> None:
        self.changes: list[dict[str, Any]] = plan.get("changes", [])
        self.kept: dict[int, State] = {}
        if "states" in plan:
            self.kept = {i: State.from_doc(st) for i, st in enumerate(plan["states"])}
            self.n = len(self.kept)
        elif "start" in plan:
            state = State.from_doc(plan["start"])
            self.kept[0], self.n = state, len(self.changes) + 1
            for i, change in enumerate(self.changes, 1):
                state = state.changed(change)
                if i % self.EVERY == 0 or i == len(self.changes):
                    self.kept[i] = state
        else:
            self.n = 0
        self.last: tuple[int, Optional[State]] = (0, self.kept.get(0))

    def __len__(self) -> int:
        return self.n

    def __bool__(self) -> bool:
        return self.n > 0

    def __getitem__(self, index: int) -> State:
        i = index + self.n if index < 0 else index
        if not 0 <= i < self.n:
            raise IndexError(f"state {index} of a plan with {self.n} states")
        if i in self.kept:
            return self.kept[i]
        j, state = self.last
        if state is None or not j <= i or i - j >= self.EVERY:
            j = i - i % self.EVERY
            state = self.kept[j]
        for change in self.changes[j:i]:
            state = state.changed(change)
        self.last = (i, state)
        return state

    def __iter__(self) -> Iterator[State]:
        if not self.n:
            return
        state = self.kept[0]
        yield state
        for i in range(1, self.n):
            state = self.kept.get(i) or state.changed(self.changes[i - 1])
            yield state


def rate(p: Optional[dict[str, Any]]) -> Optional[Fraction]:
    return None if p is None or p.get("hz") is None else Fraction(p["hz"])


def satisfies(p: Optional[dict[str, Any]], q: Optional[dict[str, Any]]) -> bool:
    """p satisfies q iff both are data of the same type and (q has no rate, or p has a rate >= q's)."""
    if p is None or q is None or p["message"] is None or q["message"] is None or p["message"] != q["message"]:
        return False
    q_hz = rate(q)
    if q_hz is None:
        return True
    p_hz = rate(p)
    return p_hz is not None and p_hz >= q_hz


class Model:
    """A plan document's model: components, connectors, environment."""

    def __init__(self, model: dict[str, Any]) -> None:
        self.comps = {c["name"]: c for c in model["components"]}
        self.conns = {c["name"]: c for c in model["connectors"]}
        self.env = [e["guarantee"] for e in model["environment"]]

    def port(self, comp: str, name: str) -> Optional[dict[str, Any]]:
        for p in self.comps[comp]["ports"]:
            if p["name"] == name:
                return p
        return None

    def mode(self, comp: str, f: dict[str, Any], state: State) -> dict[str, Any]:
        return f["degraded"] if (comp, f["name"]) in state.degraded else f["normal"]

    @staticmethod
    def guarantee(mode: dict[str, Any], port: str) -> Optional[dict[str, Any]]:
        for g in mode["guarantees"]:
            if g["port"] == port:
                return g["predicate"]
        return None

    def satisfying(self, state: State, conn: str) -> list[str]:
        """The present components whose outputs satisfy `conn` in `state`."""
        want = self.conns[conn]["guarantee"]
        out = []
        for n, comp, pname in sorted(state.roles):
            if n != conn or comp not in state.components or comp not in self.comps:
                continue
            p = self.port(comp, pname)
            if p is None or p["kind"] != "output":
                continue
            if any(pname in f["ports"] and satisfies(self.guarantee(self.mode(comp, f, state), pname), want)
                   for f in self.comps[comp]["functionalities"]):
                out.append(comp)
        return out

    def failures(self, state: State) -> list[str]:
        """Every assumption of a present functionality's current mode that does not hold."""
        present = [c for c in sorted(state.components) if c in self.comps]
        feeds: dict[tuple[str, str], list[str]] = {}
        for conn, comp, pname in sorted(state.roles):
            p = self.port(comp, pname) if comp in self.comps else None
            if comp in present and conn in self.conns and p is not None and p["kind"] == "input":
                feeds.setdefault((comp, pname), []).append(conn)
        conn_sat = {name: bool(self.satisfying(state, name)) for name in self.conns}

        def input_sat(comp: str, p: dict[str, Any]) -> bool:
            return any(conn_sat[cn] and satisfies(self.conns[cn]["guarantee"], p["assumption"])
                       for cn in feeds.get((comp, p["name"]), []))

        def holds(comp: str, f: dict[str, Any], a: dict[str, Any]) -> bool:
            for pname in f["ports"]:
                p = self.port(comp, pname)
                if p is not None and p["kind"] == "input" and input_sat(comp, p) and satisfies(p["assumption"], a):
                    return True
            return any(satisfies(e, a) for e in self.env)

        out = []
        for comp in present:
            for f in self.comps[comp]["functionalities"]:
                for a in self.mode(comp, f, state)["assumptions"]:
                    if not holds(comp, f, a):
                        out.append(f"{comp}.{f['name']} assumes {a['text']}, which does not hold")
        return out

    def relying_inputs(self, comp: str, state: State) -> list[str]:
        """Inputs of `comp` that a functionality in its normal mode (in `state`) relies on."""
        out = set()
        for f in self.comps[comp]["functionalities"]:
            if (comp, f["name"]) in state.degraded:
                continue
            for a in f["normal"]["assumptions"]:
                for pname in f["ports"]:
                    p = self.port(comp, pname)
                    if p is not None and p["kind"] == "input" and satisfies(p["assumption"], a):
                        out.add(pname)
        return sorted(out)

    def refusal(self, state: State, step: dict[str, Any]) -> Optional[str]:
        """Why `step` cannot run in `state` at all (the structural part of its preconditions)."""
        kind, comp = step["action"], step["component"]
        if kind == "create":
            if comp not in self.comps:
                return f"no component {comp} is declared"
            return f"{comp} is already in the system" if comp in state.components else None
        if comp not in state.components:
            return f"{comp} is not in the system"
        if kind == "remove":
            attached = [f"{comp}.{p} is attached to {n}" for n, c, p in sorted(state.roles) if c == comp]
            return f"{comp} is not isolated: " + "; ".join(attached) if attached else None
        if kind in ("attach", "detach"):
            if step["connector"] not in self.conns or self.port(comp, step["port"]) is None:
                return f"{comp}.{step['port']} or {step['connector']} is not declared"
            role = (step["connector"], comp, step["port"])
            if kind == "attach" and role in state.roles:
                return f"{comp}.{step['port']} is already attached to {step['connector']}"
            if kind == "detach" and role not in state.roles:
                return f"{comp}.{step['port']} is not attached to {step['connector']}"
            return None
        names = [f["name"] for f in self.comps[comp]["functionalities"]]
        fid = (comp, step["functionality"])
        if step["functionality"] not in names:
            return f"{comp} has no functionality {step['functionality']}"
        if kind == "degrade" and fid in state.degraded:
            return f"{comp}.{step['functionality']} is already degraded"
        if kind == "upgrade" and fid not in state.degraded:
            return f"{comp}.{step['functionality']} is not degraded"
        return None

    def effect(self, state: State, step: dict[str, Any]) -> State:
        kind, comp = step["action"], step["component"]
        if kind == "remove":
            return State(state.components - {comp}, [d for d in state.degraded if d[0] != comp], state.roles)
        if kind == "create":
            funcs = [(comp, f["name"]) for f in self.comps[comp]["functionalities"]]
            return State(state.components | {comp}, state.degraded | set(funcs), state.roles)
        if kind in ("attach", "detach"):
            role = (step["connector"], comp, step["port"])
            roles = state.roles | {role} if kind == "attach" else state.roles - {role}
            return State(state.components, state.degraded, roles)
        fid = (comp, step["functionality"])
        degraded = state.degraded | {fid} if kind == "degrade" else state.degraded - {fid}
        return State(state.components, degraded, state.roles)

    def differences(self, expected: State, observed: State, comps: Iterable[str]) -> list[str]:
        """What differs between two configurations, for the components `comps`, in words."""
        out = []
        for c in sorted(comps):
            if (c in expected.components) != (c in observed.components):
                out.append(f"{c} is {'running' if c in observed.components else 'not running'}, "
                           f"the plan expects it {'present' if c in expected.components else 'absent'}")
                continue
            if c not in observed.components:
                continue
            for f in self.comps[c]["functionalities"]:
                e, o = (c, f["name"]) in expected.degraded, (c, f["name"]) in observed.degraded
                if e != o:
                    out.append(f"{c}.{f['name']} is {'degraded' if o else 'normal'}, "
                               f"the plan expects {'degraded' if e else 'normal'}")
            for p in self.comps[c]["ports"]:
                e2 = sorted(n for n, cc, pp in expected.roles if cc == c and pp == p["name"])
                o2 = sorted(n for n, cc, pp in observed.roles if cc == c and pp == p["name"])
                if e2 != o2:
                    out.append(f"{c}.{p['name']} is attached to {o2 or 'nothing'}, the plan expects {e2 or 'nothing'}")
        return out


def describe(step: dict[str, Any]) -> str:
    kind, comp = step["action"], step["component"]
    if kind == "create":
        return f"create {comp} (all functionalities degraded)"
    if kind == "remove":
        return f"remove {comp}"
    if kind == "attach":
        return f"attach {comp}.{step['port']} to {step['connector']}"
    if kind == "detach":
        return f"detach {comp}.{step['port']} from {step['connector']}"
    return f"{kind} {comp}.{step['functionality']}"


def label(i: int, step: dict[str, Any]) -> str:
    return f"{i:>3}. {SYMBOLS.get(step['action'], '?')} {describe(step)}"


def replay(doc: dict[str, Any], out: Any) -> bool:
    """Replay the plan from its first state; print every state; True when all are safe."""
    model, plan = Model(doc["model"]), doc["plan"]
    steps, recorded = plan["steps"], PlanStates(plan)
    state = recorded[0] if recorded else State([], [], [])
    ok, refused = True, None
    rows = [("  0.   initial state", state)]
    for i, step in enumerate(steps, 1):
        why = model.refusal(state, step)
        if why:
            refused = (i, step, why)
            break
        state = model.effect(state, step)
        if i < len(recorded) and recorded[i].key() != state.key():
            print(f"dry run: after step {i} the embedded plan records a different state than the steps give",
                  file=out)
            ok = False
        rows.append((label(i, step), state))
    unsafe = []
    for i, (text, st) in enumerate(rows):
        bad = model.failures(st)
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(st.degraded) if c in st.components) or "-"
        print(f"{text:<60} [{'UNSAFE' if bad else 'safe'}]  degraded: {degraded}", file=out)
        for reason in bad:
            print(f"       {reason}", file=out)
        if bad:
            unsafe.append(i)
    if refused is not None:
        i, step, why = refused
        print(f"{label(i, step):<60} [REFUSED]  {why}", file=out)
        print(f"dry run: step {i} ({describe(step)}) cannot run: {why}", file=out)
        ok = False
    if unsafe:
        where = ", ".join(f"step {i} ({describe(steps[i - 1])})" if i else "the initial state" for i in unsafe)
        print(f"dry run: UNSAFE after {where}", file=out)
        ok = False
    if ok:
        print("dry run: " + (f"all {len(rows)} states are safe" if len(rows) != 1 else "the 1 state is safe"),
              file=out)
    return ok


# --- the running system ----------------------------------------------------------------------

class StepFailed(Exception):
    pass


def one(answers: dict[str, Any], key: str) -> Any:
    """The answer for `key` of a call to many; its StepFailed raised."""
    answer = answers[key]
    if isinstance(answer, StepFailed):
        raise answer
    return answer


def tool_node(tool: str) -> str:
    """The node name of one of reconf's own tools (a plan script's runtime, the manager, discover
    and drift, the status watcher, the recorder): hidden, as ROS hides a name with a leading
    underscore, so that no reader of the graph takes it for a component (docs/runtime.md#discover)."""
    safe = "".join(ch if ch.isalnum() else "_" for ch in tool)
    return f"{TOOL_PREFIX}{safe}_{os.getpid()}"


def find_node(own: str, declared: str, graph: set[str], statuses: dict[str, dict[str, str]],
              claimed: Iterable[str] = ()) -> Optional[str]:
    """A component's node: the node under its own name `own` (a fully qualified name) if it runs,
    is not `claimed` and declares no other component; else the one node of own's namespace whose
    status declares the component (`declared`), a new version's `X_2` (docs/executor.md#names)."""
    claimed = set(claimed)
    if own in graph and own not in claimed and statuses.get(own, {}).get("component", declared) == declared:
        return own
    ns = own.rsplit("/", 1)[0]
    found = [f for f, st in statuses.items() if st.get("component") == declared and f in graph
             and f.rsplit("/", 1)[0] == ns and f not in claimed]
    return found[0] if len(found) == 1 else None


class Runtime:
    """The ROS side: lifecycle and parameter services of each component's node, the graph, and
    the nodes' statuses on /diagnostics."""

    def __init__(self, name: str, namespace: str, timeout: float, node_name: str = "") -> None:
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
        ns = namespace.strip("/")
        self.namespace = f"/{ns}" if ns else ""
        self.deadline = float("inf")
        self.clients: dict[str, Any] = {}
        self.statuses: dict[str, dict[str, str]] = {}   # node fqn -> its last status
        self.heard: dict[str, float] = {}                 # node fqn -> when its last status came
        rclpy.init()
        self.node = rclpy.create_node(node_name or tool_node(f"plan_{name}"), namespace=self.namespace or None)
        self.started_at = time.monotonic()               # discovery began here
        self.graph_seen: set[str] = set()
        self.graph_since = self.started_at                # the graph last changed here
        self.endpoints_seen: Any = None                   # every topic's types and endpoint counts
        self.endpoints_at = 0.0                           # when they were last counted
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_status, qos)

    def close(self) -> None:
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

    def status(self, fqn: str) -> Optional[dict[str, str]]:
        return self.statuses.get(fqn)

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return
            self.rclpy.spin_once(self.node, timeout_sec=min(left, 0.02))

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
            self.rclpy.spin_once(self.node, timeout_sec=0.01)

    def nodes(self) -> list[str]:
        """Nodes discovered in the graph, and nodes heard on /diagnostics (a reconf node publishes
        its status at least once a second, which discovery may not have caught up with)."""
        graph = [f"{ns.rstrip('/')}/{n}" for n, ns in self.node.get_node_names_and_namespaces()]
        now = time.monotonic()
        heard = {n for n, t in self.heard.items() if now - t <= STATUS_FRESH}
        return graph + sorted(heard - set(graph))

    def graph(self) -> set[str]:
        """The nodes now, noting when the set last changed (see `Executor.settle`)."""
        nodes = set(self.nodes())
        if nodes != self.graph_seen:
            self.graph_seen, self.graph_since = nodes, time.monotonic()
        return nodes

    def settled(self, want: Callable[[set[str]], set[str]], endpoints: bool = False) -> bool:
        """Whether discovery has caught up (docs/executor.md#discovery): one announcement period
        and a margin since it began, the nodes `want(graph)` seen, and the graph unchanged for
        GRAPH_QUIET s. With `endpoints` (for reading them), every topic's publishers and
        subscribers unchanged too, and every node heard on /diagnostics in the graph itself."""
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
        return want(nodes) <= nodes and now - self.started_at >= DISCOVERY_ROUND and \
            now - self.graph_since >= GRAPH_QUIET

    def client(self, srv_type: Any, name: str) -> Any:
        if name not in self.clients:
            self.clients[name] = self.node.create_client(srv_type, name)
        return self.clients[name]

    def forget(self, fqn: str) -> None:
        """Drop the clients of a node that is gone (a new node of that name needs new ones)."""
        for name in [n for n in self.clients if n.startswith(fqn + "/")]:
            self.node.destroy_client(self.clients.pop(name))

    def call(self, srv_type: Any, name: str, request: Any) -> Any:
        """One call that changes something, sent once (reads go through `call_many`)."""
        return one(self.call_many(srv_type, {name: request}, repeat=False), name)

    def call_many(self, srv_type: Any, requests: dict[str, Any], repeat: bool = True) -> dict[str, Any]:
        """Calls to many services at once: service name -> answer, or the StepFailed that explains
        why there is none within the timeout. A read-only call (`repeat`) is sent again every
        RETRY_AFTER s while unanswered, and the first answer to any of its copies is taken: a
        request that reaches a new service before the service has matched the caller is only
        delivered at the next DDS heartbeat, seconds later, and its answer can be lost the same
        way. A call that changes something is sent once."""
        answers: dict[str, Any] = {}
        clients = {n: self.client(srv_type, n) for n in requests}
        end = time.monotonic() + min(self.timeout, self.left())
        # each request goes as soon as its service is there: one service that never comes (a node
        # just gone) must not hold back the others until the time is up
        futs: dict[str, list[Any]] = {}
        sent: dict[str, float] = {}
        while time.monotonic() < end:
            t = time.monotonic()
            for n, cli in clients.items():
                if n not in futs and cli.service_is_ready():
                    futs[n], sent[n] = [cli.call_async(requests[n])], t
                elif repeat and n in futs and t - sent[n] >= RETRY_AFTER and not any(f.done() for f in futs[n]):
                    futs[n].append(cli.call_async(requests[n]))
                    sent[n] = t
            if len(futs) == len(clients) and all(any(f.done() for f in fs) for fs in futs.values()):
                break
            self.rclpy.spin_once(self.node, timeout_sec=0.01)
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
                answers[n] = StepFailed(f"no answer from {n} within {self.timeout} s")
            elif first.exception() is not None:
                answers[n] = StepFailed(f"{n} failed: {first.exception()}")
            else:
                answers[n] = first.result()
        return answers

    def lifecycles(self, fqns: Iterable[str]) -> dict[str, Any]:
        """Lifecycle state labels of many nodes at once (a StepFailed where one did not answer)."""
        res = self.call_many(self.GetState, {f"{f}/get_state": self.GetState.Request() for f in fqns})
        return {n[:-len("/get_state")]: r if isinstance(r, StepFailed) else str(r.current_state.label)
                for n, r in res.items()}

    def get_many(self, wanted: dict[str, list[str]]) -> dict[str, Any]:
        """Parameters of many nodes at once: fqn -> {name: value}, or a StepFailed."""
        reqs = {}
        for fqn, names in wanted.items():
            req = self.GetParameters.Request()
            req.names = list(names)
            reqs[f"{fqn}/get_parameters"] = req
        res = self.call_many(self.GetParameters, reqs)
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
        req = self.ChangeState.Request()
        req.transition.id = transition_id
        res = self.call(self.ChangeState, f"{fqn}/change_state", req)
        if not res.success:
            raise StepFailed(f"{fqn} refused the lifecycle transition {name}")

    def get(self, fqn: str, names: list[str]) -> dict[str, Any]:
        return dict(one(self.get_many({fqn: names}), fqn))

    def values(self, fqn: str, names: list[str], res: Any) -> dict[str, Any]:
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
        res = self.call(self.SetParameters, f"{fqn}/set_parameters", req)
        if not res.results or not res.results[0].successful:
            reason = res.results[0].reason if res.results else "no result"
            raise StepFailed(f"{fqn} refused {name}={value!r}: {reason}")


class Observed:
    """What the executor saw of one component's node."""

    def __init__(self, comp: str, lifecycle: str, modes: dict[str, str], ports: dict[str, list[str]]) -> None:
        self.comp, self.lifecycle, self.modes, self.ports = comp, lifecycle, modes, ports

    @property
    def present(self) -> bool:
        return self.lifecycle == "active"


class Executor:
    """Applies a plan document's steps to the running system (docs/executor.md)."""

    def __init__(self, doc: dict[str, Any], args: argparse.Namespace, out: Any = sys.stdout,
                 err: Any = sys.stderr, runtime: Any = None, launcher: Any = None) -> None:
        self.doc, self.args, self.out, self.err = doc, args, out, err
        self.launcher = launcher                # a manager's fork server (docs/executor.md#launcher)
        self.own_runtime = runtime is None      # a manager lends its long-lived one
        self.plan, self.model = doc["plan"], Model(doc["model"])
        self.steps = self.plan["steps"]
        self.states = PlanStates(self.plan)
        self.renames: dict[str, str] = self.plan.get("renames", {})
        self.placed: dict[str, str] = {}        # component -> its node's name, where not its own (see `locate`)
        self.runs = {c["name"]: c.get("run") for c in doc["model"]["components"]}
        self.started: dict[str, dict[str, Any]] = {}
        self.touched: set[str] = set()
        self.timings: list[dict[str, Any]] = []
        self.rt: Any = runtime
        self.log_dir = args.log_dir or os.path.join(
            "reconf-logs", f"{doc['system']}-{datetime.datetime.now().strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")

    # --- names ---
    def declared(self, comp: str) -> str:
        """The component's name in its architecture, which its node declares in its status."""
        return self.renames.get(comp, comp)

    def is_version(self, comp: str) -> bool:
        """A new version `X@new` of a component X of the same plan (docs/executor.md#names)."""
        return comp in self.renames and self.renames[comp] in self.model.comps

    def node_name(self, comp: str) -> str:
        """The component's node's name: its own, or where `locate` found it or `do_create` put it;
        a new version not yet found, or a component whose name a new version's node has, has
        none ("X@new" and "X@elsewhere" are never a node's name)."""
        return self.placed.get(comp) or (comp if self.is_version(comp) else self.declared(comp))

    def created_mark(self, comp: str) -> str:
        return f"{self.doc['fingerprint']} {comp}"

    def locate(self, comps: Iterable[str], graph: Optional[set[str]] = None) -> None:
        """Find the nodes not under their components' names, by their statuses: a new version by
        the mark of the plan step that started it, any other component by the component its
        node declares (a node a plan started as `X@new` declares X and runs on as X). `graph`:
        the nodes, when the caller has just read them."""
        graph, ns = (set(self.rt.nodes()) if graph is None else graph), self.rt.namespace
        mine = {st.get("created", ""): fqn for fqn, st in self.rt.statuses.items() if fqn in graph}
        claimed = {f"{ns}/{n}" for n in self.placed.values()} | \
            {mine[self.created_mark(c)] for c in self.model.comps if self.is_version(c) and self.created_mark(c) in mine}
        for c in sorted(comps, key=lambda c: not self.is_version(c)):     # versions first: they claim
            if c in self.placed:
                continue
            if self.is_version(c):
                found = mine.get(self.created_mark(c))
            else:
                found = find_node(self.fqn(c), self.declared(c), graph, self.rt.statuses, claimed)
                if found == self.fqn(c):
                    continue
                if found is None and self.fqn(c) in claimed:
                    self.placed[c] = f"{self.declared(c)}@elsewhere"    # its name is a new version's node
            if found is not None:
                self.placed[c] = found.rsplit("/", 1)[1]
                claimed.add(found)

    def fresh_name(self, comp: str) -> str:
        """A node name for a new version: its component's name if no node has it, else the first
        free `<name>_<k>`."""
        base, ns = self.declared(comp), self.rt.namespace
        taken = set(self.rt.nodes()) | {f"{ns}/{n}" for n in self.placed.values()}
        k, name = 2, base
        while f"{ns}/{name}" in taken:
            name, k = f"{base}_{k}", k + 1
        return name

    def fqn(self, comp: str) -> str:
        return f"{self.rt.namespace}/{self.node_name(comp)}"

    def conn_name(self, conn: str) -> str:
        return self.renames.get(conn, conn)

    def say(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    # --- observation ---
    def observe(self, comps: Iterable[str]) -> dict[str, Observed]:
        """Read each component's node: lifecycle state, modes, attachments (absent: not in the graph,
        or finalized)."""
        comps = sorted(comps)
        graph = set(self.rt.nodes())
        self.locate(comps, graph)
        seen: dict[str, Observed] = {}
        for c in comps:
            if self.fqn(c) not in graph:
                seen[c] = Observed(c, "absent", {}, {})
        # every node at once: lifecycle states, then the active ones' modes and attachments
        states = self.rt.lifecycles(self.fqn(c) for c in comps if c not in seen)
        wanted: dict[str, list[str]] = {}
        for c in comps:
            lc = states.get(self.fqn(c))
            if c in seen or lc is None:
                continue
            if isinstance(lc, StepFailed):    # in the graph, but not answering: say so, do not guess
                seen[c] = Observed(c, "unresponsive", {}, {})
            elif lc != "active":
                seen[c] = Observed(c, "absent" if lc == "finalized" else lc, {}, {})
            else:
                info = self.model.comps[c]
                wanted[self.fqn(c)] = [f"reconf.mode.{f['name']}" for f in info["functionalities"]] + \
                    [f"reconf.port.{p['name']}" for p in info["ports"]]
        params = self.rt.get_many(wanted)
        for c in comps:
            values = params.get(self.fqn(c))
            if values is None:
                continue
            if isinstance(values, StepFailed):
                raise values
            modes = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.mode.")}
            ports = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.port.")}
            seen[c] = Observed(c, "active", modes, ports)
        return dict(sorted(seen.items()))

    def as_state(self, seen: dict[str, Observed]) -> State:
        back = {v: k for k, v in self.renames.items()}
        comps = [c for c, o in seen.items() if o.present]
        degraded = [(c, f) for c in comps for f, m in seen[c].modes.items() if m != "normal"]
        roles = [(back.get(k, k), c, p) for c in comps for p, ks in seen[c].ports.items() for k in ks]
        return State(comps, degraded, roles)

    def neighbourhood(self) -> set[str]:
        """The components the plan touches, and those attached to a connector it touches."""
        comps = {s["component"] for s in self.steps}
        conns = {s["connector"] for s in self.steps if "connector" in s}
        for st in self.states:
            conns |= {n for n, c, p in st.roles if c in comps}
        for st in self.states:
            comps |= {c for n, c, p in st.roles if n in conns}
        return comps & set(self.model.comps)

    def settle(self, expected: Iterable[str], seconds: float) -> None:
        """Let discovery catch up before reading the graph (bounded by `seconds`): every node the
        plan expects running seen, one announcement period passed, and the graph unchanged for a
        while. A node the plan expects absent but that runs must not be missed (a re-run would
        start a second one)."""
        expected = set(expected)

        def want(nodes: set[str]) -> set[str]:
            self.locate(expected, nodes)
            return {self.fqn(c) for c in expected}
        self.rt.wait(lambda: self.rt.settled(want), seconds)

    # --- the wire ---
    def wait_status(self, comp: str, cond: Callable[[dict[str, str]], bool], seconds: float) -> bool:
        return self.rt.wait(lambda: (st := self.rt.status(self.fqn(comp))) is not None and cond(st), seconds)

    @staticmethod
    def meets(func: str) -> Callable[[dict[str, str]], bool]:
        """Whether a status shows `func`'s normal assumptions met on the wire (or not observed)."""
        return lambda st: st.get(f"wire.{func}", "").split(":")[0] in ("met", "unobserved")

    def wire_before(self, step: dict[str, Any], before: State, after: State) -> None:
        """What the wire must show before the step: an upgraded functionality's assumptions met;
        a connector that loses a publisher still delivering from the ones that remain."""
        kind, comp = step["action"], step["component"]
        wait = self.args.wire_timeout
        if kind == "upgrade":
            f = step["functionality"]
            if not self.wait_status(comp, self.meets(f), wait):
                st = self.rt.status(self.fqn(comp)) or {}
                raise StepFailed(f"{comp}.{f}: its assumptions are not met on the wire "
                                 f"({st.get(f'wire.{f}', 'no status from the node')})")
        for conn in self.model.conns:
            kept = self.model.satisfying(after, conn)
            if not kept or set(kept) >= set(self.model.satisfying(before, conn)):
                continue
            names = {self.node_name(c) for c in kept}
            k = self.conn_name(conn)
            matched = len([c for n, c, p in before.roles if n == conn and c in before.components
                           and (self.model.port(c, p) or {}).get("kind") == "output"])
            for n, reader, port in sorted(after.roles):
                if n != conn or reader not in after.components or port not in self.model.relying_inputs(reader, after):
                    continue
                if self.on_demand(reader, port):
                    # data on demand (an FTM's requests): none may flow now; the reader must be
                    # matched with every publisher it has, the ones that stay among them
                    if not self.wait_status(reader, lambda st: int(st.get(f"in.{port}@{k}.publishers", "0")) >= matched,
                                            wait):
                        st = self.rt.status(self.fqn(reader)) or {}
                        raise StepFailed(f"{reader}.{port} is matched with {st.get(f'in.{port}@{k}.publishers', 'no')} "
                                         f"of the {plural(matched, 'publisher')} of {k}; taking {comp}'s away "
                                         "could leave it without one")
                    continue
                if not self.wait_status(reader, lambda st: bool(names & set(split_list(st.get(f"in.{port}.fresh", "")))),
                                        wait):
                    st = self.rt.status(self.fqn(reader)) or {}
                    raise StepFailed(f"{reader}.{port} is not receiving from {', '.join(sorted(names))} on "
                                     f"{self.conn_name(conn)} (fresh sources: {st.get(f'in.{port}.fresh') or 'none'}); "
                                     f"taking {comp}'s away would leave it without data")

    def wire_after(self, step: dict[str, Any], after: State) -> None:
        """An attached port is matched with the other side of its connector as the plan has it."""
        if step["action"] != "attach":
            return
        comp, port, conn = step["component"], step["port"], step["connector"]
        k = self.conn_name(conn)
        pubs = [c for n, c, p in after.roles if n == conn and c in after.components
                and (self.model.port(c, p) or {}).get("kind") == "output"]
        subs = [(c, p) for n, c, p in after.roles if n == conn and c in after.components
                and (self.model.port(c, p) or {}).get("kind") == "input"]
        kind = (self.model.port(comp, port) or {}).get("kind")
        wait = self.args.wire_timeout
        if kind == "output" and subs:
            if not self.wait_status(comp, lambda st: int(st.get(f"out.{port}@{k}.subscribers", "0")) >= len(subs),
                                    wait):
                raise StepFailed(f"{comp}.{port} is not matched with the {plural(len(subs), 'subscriber')} of {k} "
                                 f"within {wait} s")
        readers = subs if kind == "output" else [(comp, port)]
        for c, p in readers:
            if pubs and not self.wait_status(c, lambda st: int(st.get(f"in.{p}@{k}.publishers", "0")) >= len(pubs),
                                             wait):
                raise StepFailed(f"{c}.{p} is not matched with the {plural(len(pubs), 'publisher')} of {k} "
                                 f"within {wait} s")
        if kind == "output" and self.publishes(comp, port, after):
            # Matched counts can be stale (a publisher just gone still counted): the data decides.
            me = f"in.{{}}.from.{self.node_name(comp)}"
            for c, p in subs:
                if self.on_demand(c, p):
                    continue            # nothing flows until asked for; matched above
                if not self.wait_status(c, lambda st: me.format(p) in st, wait):
                    raise StepFailed(f"{c}.{p} has received nothing from {comp} on {k} within {wait} s")

    def on_demand(self, comp: str, port: str) -> bool:
        """Whether data reaches `comp.port` only when asked for (an FTM's requests and results,
        its status says; or its assumption has no rate): no data may flow while a step runs."""
        st = self.rt.status(self.fqn(comp)) or {}
        return st.get(f"in.{port}.on_demand") == "1" or \
            rate((self.model.port(comp, port) or {}).get("assumption")) is None

    def publishes(self, comp: str, port: str, state: State) -> bool:
        """Whether `comp.port`'s functionality guarantees data at a rate there in `state`'s mode
        (data without a rate comes on demand: an FTM's requests, say; matching is all there is
        to wait for)."""
        for f in self.model.comps[comp]["functionalities"]:
            if port in f["ports"]:
                g = self.model.guarantee(self.model.mode(comp, f, state), port)
                if g is not None and g.get("message") is not None and g.get("hz") is not None:
                    return True
        return False

    # --- the six actions ---
    def perform(self, step: dict[str, Any], before: State, after: State) -> None:
        self.rt.deadline = time.monotonic() + self.args.step_timeout
        self.wire_before(step, before, after)
        getattr(self, "do_" + step["action"])(step)
        self.wire_after(step, after)

    def expect_active(self, comp: str, when: str) -> None:
        lc = self.rt.lifecycle(self.fqn(comp))
        if lc != "active":
            raise StepFailed(f"{when}, {comp} is in lifecycle state {lc!r}")

    def command(self, comp: str) -> list[str]:
        """The component's run line, or, when it has none, a model-driven node of the architecture
        the plan reaches (`reconf-node --plan`); with the node's name and namespace."""
        run = self.runs.get(comp)
        argv = shlex.split(run) if run else ["reconf-node", "--plan", self.plan_path, comp]
        exe = shutil.which(argv[0]) or shutil.which(argv[0], path=os.path.dirname(sys.executable))
        if exe is None:
            raise StepFailed(f"{argv[0]!r} (the run command of {comp}) is not found")
        argv[0] = exe
        named = comp in self.placed and os.path.basename(exe) == "reconf-node"
        if named:       # the component it is, under the node's own name (rcl's remap rules refuse "__")
            argv[1:1] = ["--as", self.declared(comp), "--node", self.placed[comp]]
        remaps = ([f"__ns:={self.rt.namespace}"] if self.rt.namespace else []) + \
            ([f"__node:={self.placed[comp]}"] if comp in self.placed and not named else [])
        if remaps:
            argv += ["--ros-args"] if "--ros-args" not in argv else []
            for r in remaps:
                argv += ["-r", r]
        return argv

    @functools.cached_property
    def plan_path(self) -> str:
        """The plan document in the log directory, for the nodes that read it; named by its
        content, so a log directory shared by several plans gives each node its own plan."""
        text = json.dumps(self.doc, sort_keys=True)
        digest = hashlib.sha256(text.encode()).hexdigest()[:16]
        path = os.path.abspath(os.path.join(self.log_dir, f"plan-{digest}.json"))
        if not os.path.exists(path):
            os.makedirs(self.log_dir, exist_ok=True)
            tmp = f"{path}.tmp{os.getpid()}"
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.replace(tmp, path)
        return path

    def start(self, argv: list[str], log: str, env: dict[str, str]) -> tuple[Any, str]:
        """Start a node's process, in a session of its own with its own log and `env` added:
        forked by the launcher when there is one and it can, else the ordinary way."""
        if self.launcher is not None and self.launcher.can_start(argv):
            try:
                return self.launcher.start(argv, log, env=env), " (forked by the launcher)"
            except OSError as e:
                self.say(f"      the launcher could not start it ({e}); starting it the ordinary way")
        with open(log, "ab") as fh:
            proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=fh, stderr=subprocess.STDOUT,
                                    start_new_session=True, env={**os.environ, **env})
        return proc, ""

    def warm(self, first: int, last: int) -> None:
        """Let the launcher parse what the steps' new nodes will read, while the live system is
        checked."""
        for step in self.steps[first - 1:last]:
            if step["action"] == "create" and self.launcher is not None:
                try:
                    argv = self.command(step["component"])
                except StepFailed:
                    continue                    # the step itself will say so
                if self.launcher.can_start(argv):
                    try:
                        self.launcher.warm(argv)
                    except OSError:
                        return                  # the launcher is gone: creates start the ordinary way

    def do_create(self, step: dict[str, Any]) -> None:
        comp = step["component"]
        fqn = self.fqn(comp)
        if self.is_version(comp):        # X@new: a node name no other node has (X's may still run)
            self.locate([comp])
            if comp in self.placed:
                raise StepFailed(f"before the step, {comp} runs already (node {self.fqn(comp)})")
            self.placed[comp] = self.fresh_name(comp)
            fqn = self.fqn(comp)
        if fqn in self.rt.nodes() or self.rt.node.count_services(f"{fqn}/get_state"):
            raise StepFailed(f"before the step, a node {fqn} is already running")
        argv = self.command(comp)
        os.makedirs(self.log_dir, exist_ok=True)
        log = os.path.join(self.log_dir, f"{self.node_name(comp)}.log")
        proc, how = self.start(argv, log, {CREATED_ENV: self.created_mark(comp)})
        self.started[comp] = {"pid": proc.pid, "log": log, "command": shlex.join(argv), "proc": proc, "node": fqn}
        self.say(f"      started {comp}: pid {proc.pid}{how}, log {log}")
        self.rt.forget(fqn)
        t0 = time.monotonic()
        cli = self.rt.client(self.rt.GetState, f"{fqn}/get_state")
        while not cli.service_is_ready():
            if proc.poll() is not None:
                raise StepFailed(f"{shlex.join(argv)} exited with status {proc.returncode} before {comp} came up "
                                 f"(see {log})")
            self.rt.wait(cli.service_is_ready, min(0.2, self.rt.left()))
        t_up = time.monotonic()
        if self.rt.nodes().count(fqn) > 1:
            raise StepFailed(f"two nodes named {fqn} are running")
        lc = self.rt.lifecycle(fqn)
        t_state = time.monotonic()
        if lc == "unconfigured":
            self.rt.transition(fqn, self.rt.Transition.TRANSITION_CONFIGURE, "configure")
        elif lc != "inactive":
            raise StepFailed(f"after start, {comp} is in lifecycle state {lc!r}")
        self.rt.transition(fqn, self.rt.Transition.TRANSITION_ACTIVATE, "activate")
        self.say(f"      {comp}'s services seen after {t_up - t0:.2f} s (process start and discovery), first answer "
                 f"{t_state - t_up:.2f} s later, configured and activated in {time.monotonic() - t_state:.2f} s")

    def do_remove(self, step: dict[str, Any]) -> None:
        comp = step["component"]
        fqn = self.fqn(comp)
        lc = self.rt.lifecycle(fqn)
        if lc not in ("active", "inactive"):
            raise StepFailed(f"before the step, {comp} is in lifecycle state {lc!r}")
        ports = [p["name"] for p in self.model.comps[comp]["ports"]]
        attached = {n: v for n, v in self.rt.get(fqn, [f"reconf.port.{p}" for p in ports]).items() if v}
        if attached:
            raise StepFailed(f"before the step, {comp} is not isolated: "
                             + ", ".join(f"{n}={v!r}" for n, v in sorted(attached.items())))
        if lc == "active":
            self.rt.transition(fqn, self.rt.Transition.TRANSITION_DEACTIVATE, "deactivate")
        self.rt.transition(fqn, self.rt.Transition.TRANSITION_CLEANUP, "cleanup")
        self.rt.transition(fqn, self.rt.Transition.TRANSITION_UNCONFIGURED_SHUTDOWN, "shutdown")
        # finalized: the node may exit at once, which counts as removed
        try:
            lc = self.rt.lifecycle(fqn)
        except StepFailed:
            lc = "finalized"
        if lc != "finalized":
            raise StepFailed(f"after shutdown, {comp} is in lifecycle state {lc!r}")
        info = self.started.get(comp)
        if info is not None:
            proc = info["proc"]
            try:
                proc.wait(timeout=max(0.1, min(self.args.timeout, self.rt.deadline - time.monotonic())))
            except subprocess.TimeoutExpired:
                proc.terminate()
                try:
                    proc.wait(timeout=2)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
            info["ended"] = proc.returncode
        self.rt.forget(fqn)

    def do_attach(self, step: dict[str, Any]) -> None:
        self.port_step(step, attach=True)

    def do_detach(self, step: dict[str, Any]) -> None:
        self.port_step(step, attach=False)

    def port_step(self, step: dict[str, Any], attach: bool) -> None:
        comp, port, conn = step["component"], step["port"], self.conn_name(step["connector"])
        fqn, name = self.fqn(comp), f"reconf.port.{step['port']}"
        self.expect_active(comp, "before the step")
        now = self.rt.get(fqn, [name])[name]
        if (conn in now) == attach:
            raise StepFailed(f"before the step, {comp}.{port} is {'already' if attach else 'not'} attached to "
                             f"{conn} ({name}={now!r})")
        self.rt.set(fqn, name, sorted(set(now) | {conn}) if attach else [c for c in now if c != conn])

    def do_degrade(self, step: dict[str, Any]) -> None:
        self.mode_step(step, "normal", "degraded")

    def do_upgrade(self, step: dict[str, Any]) -> None:
        self.mode_step(step, "degraded", "normal")

    def mode_step(self, step: dict[str, Any], before: str, after: str) -> None:
        comp, func = step["component"], step["functionality"]
        fqn, name = self.fqn(comp), f"reconf.mode.{func}"
        self.expect_active(comp, "before the step")
        now = self.rt.get(fqn, [name])[name]
        if now != before:
            raise StepFailed(f"before the step, {comp}.{func} is {now!r}, not {before!r}")
        self.rt.set(fqn, name, after)

    # --- the run ---
    def check_touched(self, expected: State, when: str) -> None:
        # a node that answered its services may not be in this node's graph yet, nor heard on
        # /diagnostics: under load, discovery lags behind the services by seconds
        want = {self.fqn(c) for c in self.touched & expected.components}
        self.rt.wait(lambda: want <= set(self.rt.nodes()), self.args.discovery_timeout)
        seen = self.observe(self.touched)
        diffs = self.model.differences(expected, self.as_state(seen), self.touched)
        if diffs:
            raise StepFailed(f"{when}: " + "; ".join(diffs))

    def violations(self, comps: Iterable[str]) -> dict[str, int]:
        out = {}
        for c in comps:
            st = self.rt.status(self.fqn(c))
            if st is not None:
                out[c] = int(st.get("violations", "0"))
        return out

    def apply(self, first: int) -> int:
        if not confirmed(self.doc, self.args, self.out):
            return EXIT_FAILED
        t0 = time.monotonic()
        if self.own_runtime:
            self.rt = Runtime(self.doc["system"], self.args.namespace, self.args.timeout)
        try:
            return self._apply(first, t0)
        finally:
            if self.own_runtime:
                self.rt.close()

    def _apply(self, first: int, t0: float) -> int:
        start = self.states[first - 1]
        self.warm(first, self.args.to_step)
        hood = self.neighbourhood()
        self.rt.deadline = time.monotonic() + self.args.step_timeout
        self.settle(start.components & hood, self.args.discovery_timeout)
        seen = self.observe(hood)
        busy = sorted(c for c, o in seen.items() if o.lifecycle == "unresponsive")
        if busy:    # a node of a saturated host can take longer than one call's timeout to answer
            self.say(f"not answering within {self.args.timeout} s: {', '.join(busy)}; reading them again")
            seen.update(self.observe(busy))
        observed = self.as_state(seen)
        diffs = self.model.differences(start, observed, hood)
        if diffs:
            self.unusual(seen)
            return self.stale(first, observed, diffs, hood)
        watched = hood & start.components
        self.wait_status_all(watched)
        # every monitor heard from, not only the neighbourhood's: a step can reach further on the
        # wire than in the model (a suspended protocol keeps its clients waiting)
        before_violations = self.violations(start.components)
        last = self.args.to_step
        self.touched = {s["component"] for s in self.steps[first - 1:last]} & hood
        check_at = time.monotonic()
        self.say(f"the live system matches the plan's state before step {first} "
                 f"({plural(len(hood), 'component')} checked in {check_at - t0:.2f} s)")
        for i in range(first, last + 1):
            step, before, after = self.steps[i - 1], self.states[i - 1], self.states[i]
            self.say(f"{label(i, step)} ...")
            s0, at = time.monotonic(), round(time.time(), 3)
            try:
                self.perform(step, before, after)
                self.rt.deadline = time.monotonic() + self.args.step_timeout
                self.check_touched(after, f"after step {i}")
            except (StepFailed, OSError, KeyboardInterrupt) as e:
                why = "interrupted" if isinstance(e, KeyboardInterrupt) else str(e)
                self.timings.append({"step": i, "at": at, "seconds": time.monotonic() - s0, "ok": False})
                return self.failed(i, step, why, t0)
            self.timings.append({"step": i, "action": step["action"], "at": at, "seconds": time.monotonic() - s0,
                                 "ok": True})
            self.say(f"      done in {time.monotonic() - s0:.3f} s")
        end = self.states[last]
        normal = [(c, f["name"]) for c in sorted(self.touched & end.components)
                  for f in self.model.comps[c]["functionalities"] if (c, f["name"]) not in end.degraded]
        self.rt.deadline = time.monotonic() + self.args.step_timeout
        unmet = [f"{c}.{f}" for c, f in normal if not self.wait_status(c, self.meets(f), self.args.wire_timeout)]
        final = self.as_state(self.observe(hood))
        wrong = self.model.differences(end, final, hood)
        if wrong:
            return self.failed(last, self.steps[last - 1], "after the last step: " + "; ".join(wrong), t0)
        after_violations = self.violations(before_violations)
        seen_bad = {c: after_violations[c] - n for c, n in before_violations.items()
                    if after_violations.get(c, n) > n}
        total = time.monotonic() - t0
        upto = "" if last == len(self.steps) else f"; stopped after step {last} as asked (--to-step)"
        done = last - first + 1
        self.say((f"all {done} steps" if done != 1 else "the 1 step") + f" done in {total:.2f} s "
                 f"(checking the live system {check_at - t0:.2f} s, steps "
                 f"{sum(t['seconds'] for t in self.timings):.2f} s){upto}")
        if unmet or seen_bad:
            if unmet:
                print(f"but on the wire, the assumptions of {', '.join(unmet)} are not met", file=self.err)
            for c, n in sorted(seen_bad.items()):
                print(f"but the monitor of {c} saw {plural(n, 'violation')} of a normal mode's assumption "
                      "during the run",
                      file=self.err)
            self.report("violated", first, observed=final)
            return EXIT_FAILED
        heard = len(before_violations)
        self.say("on the wire: every functionality the plan touched meets its assumptions, and "
                 + (f"none of the {heard} monitors heard from saw" if heard != 1 else
                    "the 1 monitor heard from did not see")
                 + " a normal mode's assumption violated during the run")
        self.report("done", first, observed=final)
        return EXIT_OK

    def wait_status_all(self, comps: Iterable[str]) -> None:
        """Wait (bounded) for a status from each running component, so violations can be counted."""
        want = list(comps)
        self.rt.wait(lambda: all(self.rt.status(self.fqn(c)) is not None for c in want), 3.0)

    def unusual(self, seen: dict[str, Observed]) -> None:
        """Say which nodes are neither absent nor active (inactive, unresponsive, …)."""
        for c, o in sorted(seen.items()):
            if o.lifecycle not in ("absent", "active"):
                print(f"    ({c} is {o.lifecycle}: not counted as present)", file=self.err)

    def stale(self, first: int, observed: State, diffs: list[str], hood: set[str]) -> int:
        print(f"refusing to apply: the live system does not match the plan's state before step {first}:",
              file=self.err)
        for d in diffs:
            print(f"  - {d}", file=self.err)
        matches = [i for i, s in enumerate(self.states) if not self.model.differences(s, observed, hood)]
        if matches:
            i = matches[-1]
            print(f"It matches the state after step {i}" + (" (the plan's last: it was applied already)"
                                                           if i == len(self.steps) else "")
                  + (f"; resume with --from-step {i + 1}" if i < len(self.steps) else "") + ".", file=self.err)
        else:
            print("Plan again from the running system (the plan is stale).", file=self.err)
        self.report("stale", first, observed=observed)
        return EXIT_FAILED

    def failed(self, i: int, step: dict[str, Any], why: str, t0: float) -> int:
        print(f"step {i} ({describe(step)}) FAILED: {why}", file=self.err)
        self.rt.deadline = time.monotonic() + self.args.step_timeout
        try:
            seen = self.observe(self.model.comps)
            observed: Optional[State] = self.as_state(seen)
        except StepFailed as e:
            print(f"could not observe the system after the failure: {e}", file=self.err)
            observed, seen = None, {}
        if observed is not None:
            print("Observed configuration (read from the running nodes):\n    " + observed.describe(), file=self.err)
            self.unusual(seen)
            bad = self.model.failures(observed)
            if bad:
                print("It is NOT valid:", file=self.err)
                for b in bad:
                    print(f"  - {b}", file=self.err)
            else:
                print("It is valid: every assumption of every present functionality holds in the model.",
                      file=self.err)
            for k, name in ((i - 1, "before"), (i, "after")):
                if not self.model.differences(self.states[k], observed, self.model.comps):
                    print(f"It is the plan's state {name} step {i}.", file=self.err)
        if self.started:
            print("Processes this run started:", file=self.err)
            for c, info in sorted(self.started.items()):
                proc = info["proc"]
                alive = proc.poll() is None
                if alive and self.args.stop_started:
                    proc.terminate()
                    try:
                        proc.wait(timeout=3)
                    except subprocess.TimeoutExpired:
                        proc.kill()
                    print(f"  {c}: pid {info['pid']} stopped (--stop-started), log {info['log']}", file=self.err)
                else:
                    state = "running" if alive else f"exited with status {proc.returncode}"
                    print(f"  {c}: pid {info['pid']} {state}, log {info['log']}", file=self.err)
            if self.args.stop_started:
                seen = self.observe(self.model.comps)
                observed = self.as_state(seen)
        path = self.report("failed", i, observed=observed, failed_step=i, why=why)
        print(f"To recover, plan from the observed configuration:\n"
              f"    reconf recover {path} -o recover.py           (on to the plan's target)\n"
              f"    reconf recover {path} --back -o recover.py    (back to the plan's start)", file=self.err)
        return EXIT_FAILED

    def report(self, outcome: str, first: int, observed: Optional[State], failed_step: Optional[int] = None,
               why: Optional[str] = None) -> str:
        """Write the run's report (JSON); return its path."""
        path = self.args.report or (f"reconf-{self.doc['system']}-{outcome}.json" if outcome != "done" else "")
        if not path:
            return ""
        body = {"format_version": 1, "tool": "reconf", "kind": "run-report", "outcome": outcome,
                "system": self.doc["system"], "fingerprint": self.doc["fingerprint"], "from_step": first,
                "failed_step": failed_step, "reason": why,
                "observed": None if observed is None else observed.to_doc(),
                "observed_valid": None if observed is None else not self.model.failures(observed),
                "timings": self.timings,
                "started": {c: {k: v for k, v in info.items() if k != "proc"} for c, info in self.started.items()},
                "plan_document": self.doc}
        tmp = f"{path}.tmp{os.getpid()}"
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(body, fh, indent=1, sort_keys=True)
        os.replace(tmp, path)
        print(f"report: {path}", file=self.err if outcome != "done" else self.out)
        return path


def confirmed(doc: dict[str, Any], args: argparse.Namespace, out: Any) -> bool:
    """List the steps to apply; unless --yes, ask."""
    first, last = args.from_step, args.to_step
    if args.quiet_list and args.yes:      # a manager: its client has listed them
        return True
    print(f"applying steps {first}..{last} of the plan for {doc['system']} ({doc['fingerprint']})", file=out)
    for i in range(first, last + 1):
        print(label(i, doc["plan"]["steps"][i - 1]), file=out)
    if args.yes:
        return True
    try:
        answer = input("Apply these steps to the running system? [y/N] ")
    except EOFError:
        answer = ""
    if answer.strip().lower() in ("y", "yes"):
        return True
    print("nothing done", file=out)
    return False


def manager_socket(namespace: str = "") -> str:
    """Where the manager of this ROS domain (and namespace) listens by default."""
    base = os.environ.get("XDG_RUNTIME_DIR") or os.path.join("/tmp", f"reconf-{os.getuid()}")
    ns = namespace.strip("/").replace("/", "_")
    return os.path.join(base, "reconf", f"manager-{os.environ.get('ROS_DOMAIN_ID', '0')}{'-' + ns if ns else ''}.sock")


def via_manager(doc: dict[str, Any], argv: list[str], args: argparse.Namespace, path: str) -> int:
    """Have a running manager (`python -m reconf_ros.manager`) apply the plan: it has discovered
    the system already, so no discovery wait here (docs/executor.md#manager). Output streams back."""
    import socket
    if not confirmed(doc, args, sys.stdout):
        return EXIT_FAILED
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(path)
    except OSError as e:
        print(f"no reconf manager at {path} ({e.strerror or e}): start one with `python -m reconf_ros.manager`, "
              "or leave out --manager to apply the plan from this process", file=sys.stderr)
        return EXIT_USAGE
    request = {"doc": doc, "argv": argv + ["--yes", "--quiet-list", "--cwd", os.getcwd()]}
    with sock, sock.makefile("rwb") as stream:
        stream.write(json.dumps(request).encode() + b"\n")
        stream.flush()
        for line in stream:
            msg = json.loads(line)
            if "exit" in msg:
                return int(msg["exit"])
            print(msg.get("text", ""), end="", file=sys.stderr if msg.get("stream") == "err" else sys.stdout,
                  flush=True)
    print("the reconf manager closed the connection before the plan finished", file=sys.stderr)
    return EXIT_FAILED


def arguments(doc: dict[str, Any]) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=f"Reconfiguration plan for {doc['system']} ({doc['fingerprint']}).")
    ap.add_argument("--dry-run", action="store_true", help="replay the plan against the embedded model; no ROS")
    ap.add_argument("--yes", "-y", action="store_true", help="do not ask for confirmation")
    ap.add_argument("--from-step", type=int, default=1, metavar="N", help="resume at step N (1-based)")
    ap.add_argument("--to-step", type=int, default=0, metavar="N", help="stop after step N (default: the last)")
    ap.add_argument("--timeout", type=float, default=5.0, metavar="S", help="per service call, in seconds")
    ap.add_argument("--step-timeout", type=float, default=30.0, metavar="S", help="per step, in seconds")
    ap.add_argument("--wire-timeout", type=float, default=10.0, metavar="S",
                    help="how long a step waits for the wire (matching, data, assumptions met)")
    ap.add_argument("--discovery-timeout", type=float, default=5.0, metavar="S",
                    help="how long to wait for the plan's running nodes to be discovered")
    ap.add_argument("--namespace", default="", help="namespace of the components' nodes")
    ap.add_argument("--log-dir", default="", metavar="DIR",
                    help="where started processes write their output (default ./reconf-logs/SYSTEM-TIME-PID)")
    ap.add_argument("--report", default="", metavar="FILE",
                    help="write the run's report (JSON) here; on failure one is always written")
    ap.add_argument("--stop-started", action="store_true",
                    help="on failure, stop the processes this run started (they are named either way)")
    ap.add_argument("--manager", nargs="?", const="default", default="", metavar="SOCKET",
                    help="let a running reconf manager apply the plan (default socket: this ROS domain's)")
    ap.add_argument("--quiet-list", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--cwd", default="", help=argparse.SUPPRESS)
    return ap


def parse(doc: dict[str, Any], argv: Optional[list[str]],
          ap: Optional[argparse.ArgumentParser] = None) -> argparse.Namespace:
    """The script's arguments, checked (argparse exits with status 2 on bad ones; `reconf up`
    passes a parser of `arguments(doc)` whose errors are its own)."""
    ap = ap or arguments(doc)
    args = ap.parse_args(argv)
    steps = doc["plan"]["steps"]
    if not 1 <= args.from_step <= max(1, len(steps)):
        ap.error(f"--from-step must be between 1 and {max(1, len(steps))}")
    args.to_step = args.to_step or len(steps)
    if not args.from_step <= args.to_step <= len(steps):
        ap.error(f"--to-step must be between --from-step and {len(steps)}")
    if min(args.timeout, args.step_timeout, args.wire_timeout, args.discovery_timeout) <= 0:
        ap.error("timeouts must be positive")
    return args


def main(doc: dict[str, Any], argv: Optional[list[str]] = None) -> int:
    try:
        sys.stdout.reconfigure(errors="replace")  # type: ignore[union-attr]
    except AttributeError:
        pass
    args = parse(doc, argv)
    plan = doc["plan"]
    steps = plan["steps"]
    print(f"plan for {doc['system']} ({doc['fingerprint']}): {plural(len(steps), 'step')}, "
          f"strategy {plan.get('strategy')}, "
          f"disruption {plan.get('disruption')}")
    for key, value in sorted(doc.get("evidence", {}).items()):
        print(f"evidence: {key}: {json.dumps(value, sort_keys=True)}")
    safe = replay(doc, sys.stdout)
    if args.dry_run or not safe:
        if not safe and not args.dry_run:
            print("refusing to apply an unsafe plan", file=sys.stderr)
        return EXIT_OK if safe else EXIT_FAILED
    if not steps:
        print("nothing to do")
        return EXIT_OK
    if args.manager:
        forwarded = [f"--{k.replace('_', '-')}={getattr(args, k)}" for k in (
            "from_step", "to_step", "timeout", "step_timeout", "wire_timeout", "discovery_timeout", "namespace")]
        forwarded += [f"--{k.replace('_', '-')}={os.path.abspath(getattr(args, k))}" for k in ("log_dir", "report")
                      if getattr(args, k)]      # the manager writes them: absolute paths
        forwarded += ["--stop-started"] if args.stop_started else []
        return via_manager(doc, forwarded, args,
                           manager_socket(args.namespace) if args.manager == "default" else args.manager)
    import importlib.util
    if importlib.util.find_spec("rclpy") is None:
        print("ROS 2 is not available (no module rclpy): install reconf with its `ros` extra "
              "(pip install 'reconf[ros]'), or source a ROS 2 installation; --dry-run needs neither.", file=sys.stderr)
        return EXIT_USAGE
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    return Executor(doc, args).apply(args.from_step)

DOC = json.loads(r"""{
 "command": "plan",
 "degradation": {
  "functionalities": {
   "talker_v2.talk": 1
  },
  "longest": 1,
  "longest_functionality": "talker_v2.talk"
 },
 "evidence": {
  "python_engine": "all 6 states valid"
 },
 "fingerprint": "sha256:031278264f8066602fcba333e91cc6f82459189e5ae0477d78be2d543c022981",
 "format_version": 2,
 "model": {
  "components": [
   {
    "deployed": true,
    "functionalities": [
     {"criticality": 1, "degraded": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": null, "message": null, "text": "nothing"}}]}, "name": "talk", "normal": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": "10", "message": "String", "text": "String @ 10 Hz"}}]}, "ports": ["out"]}
    ],
    "host": "robot",
    "name": "talker",
    "ports": [
     {"assumption": null, "kind": "output", "message": "String", "name": "out"}
    ],
    "replaces": null,
    "run": "reconf-node reconf_ros.demo.chatter:talker"
   },
   {
    "deployed": true,
    "functionalities": [
     {"criticality": 1, "degraded": {"assumptions": [], "guarantees": []}, "name": "listen", "normal": {"assumptions": [{"hz": "10", "message": "String", "text": "String @ 10 Hz"}], "guarantees": []}, "ports": ["in"]}
    ],
    "host": "robot",
    "name": "listener",
    "ports": [
     {"assumption": {"hz": "10", "message": "String", "text": "String @ 10 Hz"}, "kind": "input", "message": "String", "name": "in"}
    ],
    "replaces": null,
    "run": "reconf-node reconf_ros.demo.chatter:listener"
   },
   {
    "deployed": false,
    "functionalities": [
     {"criticality": 1, "degraded": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": null, "message": null, "text": "nothing"}}]}, "name": "talk", "normal": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": "10", "message": "String", "text": "String @ 10 Hz"}}]}, "ports": ["out"]}
    ],
    "host": "robot",
    "name": "talker_v2",
    "ports": [
     {"assumption": null, "kind": "output", "message": "String", "name": "out"}
    ],
    "replaces": "talker",
    "run": "reconf-node reconf_ros.demo.chatter:talker_v2"
   }
  ],
  "connectors": [
   {
    "guarantee": {
     "hz": "10",
     "message": "String",
     "text": "String @ 10 Hz"
    },
    "kind": "topic",
    "name": "/chatter",
    "publishers": [
     ["talker", "out"]
    ],
    "single": false,
    "single_publisher": false,
    "subscribers": [
     ["listener", "in"]
    ]
   }
  ],
  "environment": [],
  "hosts": [],
  "messages": [
   {
    "name": "String",
    "ros_type": "std_msgs/msg/String"
   }
  ],
  "name": "chatter"
 },
 "operation": "replace talker",
 "plan": {
  "changes": [
   {"add": {"components": ["talker_v2"], "degraded": [["talker_v2", "talk"]]}},
   {"drop": {"degraded": [["talker_v2", "talk"]]}},
   {"add": {"roles": [["/chatter", "talker_v2", "out"]]}},
   {"drop": {"roles": [["/chatter", "talker", "out"]]}},
   {"drop": {"components": ["talker"]}}
  ],
  "disruption": 1,
  "left_degraded": [],
  "notes": [],
  "renames": {},
  "start": {
   "components": ["listener", "talker"],
   "degraded": [],
   "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"]]
  },
  "steps": [
   {"action": "create", "component": "talker_v2"},
   {"action": "upgrade", "component": "talker_v2", "functionality": "talk"},
   {"action": "attach", "component": "talker_v2", "connector": "/chatter", "port": "out"},
   {"action": "detach", "component": "talker", "connector": "/chatter", "port": "out"},
   {"action": "remove", "component": "talker"}
  ],
  "strategy": "default",
  "verification": "full"
 },
 "system": "chatter",
 "tool": "reconf",
 "verdict": "plan"
}""")

if __name__ == "__main__":
    sys.exit(main(DOC))
