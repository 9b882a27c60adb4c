#!/usr/bin/env python3
"""Reconfiguration plan for the ROS 2 system chatter: 7 steps, strategy paper.

Architecture fingerprint: sha256:17c989dbb5df61a6894b234c81e1123137d50bb228850ec81b63050cbff9e9c5

    python3 this_file.py --dry-run     replay the plan against the embedded model (no ROS needed)
    python3 this_file.py               apply the plan to the running system (needs rclpy)

Options: --yes (no confirmation prompt), --from-step N (resume at step N), --timeout S (per
service call), --step-timeout S (per step), --wire-timeout S (wait for matching and data),
--namespace NS (of the components' nodes), --log-dir DIR (output of started processes),
--report FILE (the run's report, JSON), --stop-started (on failure, stop what this run started).
Exit status: 0 every step done and the wire showed no violated assumption (or, with --dry-run,
every state safe); 1 a state is unsafe, the live system does not match the plan, a step failed,
or the monitors saw a violated assumption; 2 bad usage or ROS 2 not available; 130 interrupted
(SIGINT or SIGTERM: the run stops at the end of the step, at once on a second signal, and
writes its report).

Each component runs one lifecycle node named after it that implements the reconf control
interface (docs/control-interface.md). The executor below is the modules of reconf_ros/executor/,
joined as they are (docs/executor.md); the plan is the JSON document at the end.

Generated from the plan below; edit the plan, not this file.
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import hmac
import json
import os
import re
import secrets
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable, Collection, Iterable, Iterator, Optional, Protocol, Sequence, TypedDict


# --- reconf_ros/executor/steps.py ---

# The symbol of each action, as `reconf plan` prints it (held to the checker's action registry
# by tests/test_tables.py).
SYMBOLS = {"create": "+", "remove": "-", "attach": "\u2192", "detach": "\u00d7", "degrade": "\u2193",
           "upgrade": "\u2191"}
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class PredicateDoc(TypedDict):
    """`T @ r` as data: `message` None for `nothing`, `hz` an exact fraction as text or None."""
    message: Optional[str]
    hz: Optional[str]
    text: str


class PortDoc(TypedDict):
    name: str
    kind: str                          # "input" or "output"
    message: str
    assumption: Optional[PredicateDoc]


class GuaranteeDoc(TypedDict):
    port: str
    predicate: PredicateDoc


class ModeDoc(TypedDict):
    assumptions: list[PredicateDoc]
    guarantees: list[GuaranteeDoc]


class FunctionalityDoc(TypedDict):
    name: str
    ports: list[str]
    criticality: int
    normal: ModeDoc
    degraded: ModeDoc


class ComponentDoc(TypedDict, total=False):
    name: str
    deployed: bool
    replaces: Optional[str]
    run: Optional[str]
    host: Optional[str]
    ports: list[PortDoc]
    functionalities: list[FunctionalityDoc]
    node: dict[str, Any]               # not a reconf node: how its adapter drives it (docs/adapter.md)


class ConnectorDoc(TypedDict, total=False):
    name: str
    kind: str                          # "topic" or "service"
    guarantee: PredicateDoc
    single: bool


class EnvironmentDoc(TypedDict):
    name: str
    guarantee: PredicateDoc


class ModelDoc(TypedDict, total=False):
    """The architecture as plain data (`codegen.ros2.model_data`)."""
    name: str
    components: list[ComponentDoc]
    connectors: list[ConnectorDoc]
    environment: list[EnvironmentDoc]


@dataclass(frozen=True)
class Step:
    """One action of a plan: `component` always; `port` and `connector` for attach and detach,
    `functionality` for degrade and upgrade."""
    action: str
    component: str
    port: str = ""
    connector: str = ""
    functionality: str = ""

    @staticmethod
    def from_doc(d: dict[str, Any]) -> "Step":
        return Step(str(d["action"]), str(d["component"]), str(d.get("port", "")), str(d.get("connector", "")),
                    str(d.get("functionality", "")))

    @property
    def role(self) -> tuple[str, str, str]:
        """The attachment an attach or a detach is about: (connector, component, port)."""
        return (self.connector, self.component, self.port)

    def describe(self) -> str:
        if self.action == "create":
            return f"create {self.component} (all functionalities degraded)"
        if self.action == "remove":
            return f"remove {self.component}"
        if self.action == "attach":
            return f"attach {self.component}.{self.port} to {self.connector}"
        if self.action == "detach":
            return f"detach {self.component}.{self.port} from {self.connector}"
        return f"{self.action} {self.component}.{self.functionality}"

    def label(self, i: int) -> str:
        """The step as a numbered line of a plan: `  3. → attach talker_v2.out to /chatter`."""
        return f"{i:>3}. {SYMBOLS.get(self.action, '?')} {self.describe()}"


def plan_steps(doc: dict[str, Any]) -> list[Step]:
    """The steps of a plan document, typed."""
    return [Step.from_doc(s) for s in doc["plan"]["steps"]]


def batches(doc: dict[str, Any]) -> list[tuple[int, int]]:
    """The plan's batches: (first, last) step, from 1, of each run of steps carried out together
    (docs/executor.md#batches)."""
    return [(int(a), int(b)) for a, b in doc["plan"].get("batches") or []]


def batch_end(ctx: Any, i: int, last: int) -> int:
    """The last step to perform together with step `i` (`i` itself when it is in no batch): the
    end of its batch, or `last`, where the run stops first. A run that starts inside a batch
    performs the rest of it together: any part of a batch is one (docs/soundness.md#batches)."""
    for a, b in ctx.batches:
        if a <= i <= b:
            return min(b, last)
    return i


def restoring(doc: dict[str, Any]) -> int:
    """How many first steps of a recovery's plan restore validity (docs/executor.md#failure-and-recovery)."""
    return int((doc["plan"].get("recovery") or {}).get("restore", 0))


def orphans(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """The nodes a recovery's plan ends before its first step (docs/executor.md#recovering-from-the-live-system)."""
    return list((doc["plan"].get("recovery") or {}).get("orphans") or [])


def join_list(items: Iterable[str]) -> str:
    return ",".join(sorted(items))


def plural(n: int, word: str, many: str = "") -> str:
    """A count and its noun in agreement: `1 step`, `3 steps`."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


# --- reconf_ros/executor/plan_states.py ---

Degraded = tuple[str, str]           # (component, functionality)
Role = tuple[str, str, str]          # (connector, component, port)


class State:
    """A configuration: present components, degraded (component, functionality), roles
    (connector, component, port)."""

    def __init__(self, components: Iterable[str], degraded: Iterable[Any], roles: Iterable[Any]) -> None:
        # frozensets are taken as they are (a state derived from another shares its unchanged parts)
        self.components: frozenset[str] = components if isinstance(components, frozenset) else frozenset(components)
        self.degraded: frozenset[Degraded] = degraded if isinstance(degraded, frozenset) \
            else frozenset((d[0], d[1]) for d in degraded)
        self.roles: frozenset[Role] = roles if isinstance(roles, frozenset) \
            else frozenset((r[0], r[1], r[2]) for r in roles)

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

    def key(self) -> tuple[frozenset[str], frozenset[Degraded], frozenset[Role]]:
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

    def alone(self, before: State, i: int) -> State:
        """`before` with step `i`'s change alone applied (format 2), or the state after step `i`
        (format 1, which has no batches)."""
        return before.changed(self.changes[i - 1]) if self.changes else self[i]

    def __iter__(self) -> Iterator[State]:
        if not self.n:
            return
        state = self.kept[0]
        yield state
        for i in range(1, self.n):
            state = self.kept.get(i) or state.changed(self.changes[i - 1])
            yield state


Timed = tuple[int, float, float, bool]      # a step as a run timed it: (step, began, ended, ok)


def degraded_spans(states: PlanStates, timed: Sequence[Timed], removes: Collection[int],
                   end: float) -> dict[str, list[tuple[float, float]]]:
    """Each functionality's degraded spans in a run ("comp.func" -> (began, ended) pairs), from
    the first timed step's start: a step takes effect at its own end, in the order the steps
    ended (the steps of a batch overlap, on distinct components: docs/executor.md#batches), but
    a component's remove (its step in `removes`) ends its spans at the remove's start (it serves
    no one while it goes, as the plan's estimate counts); a step that failed changed nothing of
    the plan's; a span still open ends at `end`. What `reconf timeline` draws and a run's last
    lines sum (docs/soundness.md#seconds-on-the-wire)."""
    if not timed:
        return {}
    first = min(timed)
    state = states[first[0] - 1]
    since = {f"{c}.{f}": first[1] for c, f in state.degraded}
    spans: dict[str, list[tuple[float, float]]] = {}
    for step, began, ended, ok in sorted(timed, key=lambda t: t[2]):
        if not ok:
            continue
        state = states.alone(state, step)
        now = {f"{c}.{f}" for c, f in state.degraded}
        for name in now - set(since):
            since[name] = ended
        stop = began if step in removes else ended
        for name in set(since) - now:
            start = since.pop(name)
            spans.setdefault(name, []).append((start, max(stop, start)))
    for name, start in since.items():
        spans.setdefault(name, []).append((start, max(end, start)))
    return spans


# --- reconf_ros/executor/semantics.py ---

def rate(p: Optional[PredicateDoc]) -> Optional[Fraction]:
    return None if p is None or p.get("hz") is None else Fraction(str(p["hz"]))


def satisfies(p: Optional[PredicateDoc], q: Optional[PredicateDoc]) -> bool:
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

    def __init__(self, model: ModelDoc) -> None:
        self.comps: dict[str, ComponentDoc] = {c["name"]: c for c in model["components"]}
        self.conns: dict[str, ConnectorDoc] = {c["name"]: c for c in model["connectors"]}
        self.env: list[PredicateDoc] = [e["guarantee"] for e in model["environment"]]

    def port(self, comp: str, name: str) -> Optional[PortDoc]:
        for p in self.comps[comp]["ports"]:
            if p["name"] == name:
                return p
        return None

    def port_kind(self, comp: str, name: str) -> str:
        """"input", "output", or "" for a port the model does not declare."""
        p = self.port(comp, name) if comp in self.comps else None
        return "" if p is None else p["kind"]

    def mode(self, comp: str, f: FunctionalityDoc, state: State) -> ModeDoc:
        return f["degraded"] if (comp, f["name"]) in state.degraded else f["normal"]

    @staticmethod
    def guarantee(mode: ModeDoc, port: str) -> Optional[PredicateDoc]:
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
            if self.port_kind(comp, pname) != "output":
                continue
            if any(pname in f["ports"] and satisfies(self.guarantee(self.mode(comp, f, state), pname), want)
                   for f in self.comps[comp]["functionalities"]):
                out.append(comp)
        return out

    def failures(self, state: State) -> list[str]:
        """Every assumption of a present functionality's current mode that does not hold, in words."""
        return [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in self.failing(state)]

    def failing(self, state: State) -> list[tuple[str, str, str]]:
        """(component, functionality, assumption's text) of every assumption of a present
        functionality's current mode that does not hold."""
        present = [c for c in sorted(state.components) if c in self.comps]
        feeds: dict[tuple[str, str], list[str]] = {}
        for conn, comp, pname in sorted(state.roles):
            if comp in present and conn in self.conns and self.port_kind(comp, pname) == "input":
                feeds.setdefault((comp, pname), []).append(conn)
        conn_sat = {name: bool(self.satisfying(state, name)) for name in self.conns}

        def input_sat(comp: str, p: PortDoc) -> bool:
            return any(conn_sat[cn] and satisfies(self.conns[cn]["guarantee"], p["assumption"])
                       for cn in feeds.get((comp, p["name"]), []))

        def holds(comp: str, f: FunctionalityDoc, a: PredicateDoc) -> bool:
            for pname in f["ports"]:
                p = self.port(comp, pname)
                if p is not None and p["kind"] == "input" and input_sat(comp, p) and satisfies(p["assumption"], a):
                    return True
            return any(satisfies(e, a) for e in self.env)

        out: list[tuple[str, str, str]] = []
        for comp in present:
            for f in self.comps[comp]["functionalities"]:
                for a in self.mode(comp, f, state)["assumptions"]:
                    if not holds(comp, f, a):
                        out.append((comp, f["name"], a["text"]))
        return out

    def relying_inputs(self, comp: str, state: State) -> list[str]:
        """Inputs of `comp` that a functionality in its normal mode (in `state`) relies on."""
        return sorted({p for f in self.comps[comp]["functionalities"] if (comp, f["name"]) not in state.degraded
                       for p, _ in self.relied_on(comp, f)})

    def relied_on(self, comp: str, f: FunctionalityDoc) -> list[tuple[str, PredicateDoc]]:
        """The inputs of `comp` that functionality `f`'s normal assumptions rely on, each with the
        assumption it meets."""
        out = []
        for a in f["normal"]["assumptions"]:
            for pname in f["ports"]:
                p = self.port(comp, pname)
                if p is not None and p["kind"] == "input" and satisfies(p["assumption"], a):
                    out.append((pname, a))
        return out

    def refusal(self, state: State, step: Step) -> Optional[str]:
        """Why `step` cannot run in `state` at all (the structural part of its preconditions)."""
        comp = step.component
        if step.action == "create":
            if comp not in self.comps:
                return f"no component {comp} is declared"
            return f"{comp} is already in the system" if comp in state.components else None
        if comp not in state.components:
            return f"{comp} is not in the system"
        if step.action == "remove":
            attached = [f"{comp}.{p} is attached to {n}" for n, c, p in sorted(state.roles) if c == comp]
            return f"{comp} is not isolated: " + "; ".join(attached) if attached else None
        if step.action in ("attach", "detach"):
            return self._port_refusal(state, step)
        names = [f["name"] for f in self.comps[comp]["functionalities"]]
        fid = (comp, step.functionality)
        if step.functionality not in names:
            return f"{comp} has no functionality {step.functionality}"
        if step.action == "degrade" and fid in state.degraded:
            return f"{comp}.{step.functionality} is already degraded"
        if step.action == "upgrade" and fid not in state.degraded:
            return f"{comp}.{step.functionality} is not degraded"
        return None

    def _port_refusal(self, state: State, step: Step) -> Optional[str]:
        where = f"{step.component}.{step.port}"
        if step.connector not in self.conns or self.port(step.component, step.port) is None:
            return f"{where} or {step.connector} is not declared"
        if step.action == "attach" and step.role in state.roles:
            return f"{where} is already attached to {step.connector}"
        if step.action == "detach" and step.role not in state.roles:
            return f"{where} is not attached to {step.connector}"
        return None

    def effect(self, state: State, step: Step) -> State:
        comp = step.component
        if step.action == "remove":
            return State(state.components - {comp}, [d for d in state.degraded if d[0] != comp], state.roles)
        if step.action == "create":
            funcs = [(comp, f["name"]) for f in self.comps[comp]["functionalities"]]
            return State(state.components | {comp}, state.degraded | set(funcs), state.roles)
        if step.action in ("attach", "detach"):
            roles = state.roles | {step.role} if step.action == "attach" else state.roles - {step.role}
            return State(state.components, state.degraded, roles)
        fid = (comp, step.functionality)
        degraded = state.degraded | {fid} if step.action == "degrade" else state.degraded - {fid}
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


# --- reconf_ros/executor/status.py ---

STATUS_PREFIX = "reconf:"          # a status's name: "reconf:<node fqn>"
CREATED_ENV = "RECONF_CREATED"     # "<model fingerprint> <component>", given to the processes a plan starts
HOLD_FD_ENV = "RECONF_HOLD_FD"     # a held node process's end of its pipe to the launcher (docs/executor.md#held)
STATUS_FRESH = 2.5                 # s a status counts as a sign of life (nodes repeat theirs every second)
TOOL_PREFIX = "_reconf_"           # reconf's own nodes: hidden (a leading underscore), never a component
# std_msgs/String "<since> <node fqn>:<input> ...": asks for statuses (docs/control-interface.md#asked-status)
ASK_TOPIC = "/reconf/ask_status"
ASK_DEPTH = 10                     # its QoS: reliable, volatile, keep last ASK_DEPTH
ASK_SPAN = 10.0                    # s after `since` that a node keeps an ask

Status = dict[str, str]            # a node's last status: key -> value


def parse_status(values: Iterable[Any]) -> Status:
    """A DiagnosticStatus's key-values as a dict (the keys are in docs/control-interface.md)."""
    return {kv.key: kv.value for kv in values}


def ask_text(since: float, inputs: Iterable[tuple[str, str]]) -> str:
    """An ask: each (node fqn, input) publishes its node's status once it has received from a
    publisher after `since` (wall clock), once per publisher (docs/control-interface.md#asked-status)."""
    return " ".join([f"{since:.6f}"] + [f"{fqn}:{port}" for fqn, port in inputs])


def parse_ask(text: str) -> tuple[float, list[tuple[str, str]]]:
    """`ask_text`'s (since, [(node fqn, input)]); anything malformed is (0.0, [])."""
    head, *rest = text.split() or ["x"]
    try:
        since = float(head)
    except ValueError:
        return 0.0, []
    return since, [(f, p) for f, sep, p in (w.rpartition(":") for w in rest) if sep]


def tool_node(tool: str, pid: Optional[int] = None) -> str:
    """The node name of one of reconf's own tools (a plan script's runtime, the manager, discover
    and drift, the status watcher, the recorder, a held process: docs/executor.md#held) in process
    `pid` (default: this one): hidden, as ROS hides a name with a leading underscore, so that no
    reader of the graph takes it for a component (docs/runtime.md#discover)."""
    safe = "".join(ch if ch.isalnum() else "_" for ch in tool)
    return f"{TOOL_PREFIX}{safe}_{os.getpid() if pid is None else pid}"


def find_node(own: str, declared: str, graph: set[str], statuses: dict[str, Status],
              claimed: Iterable[str] = ()) -> Optional[str]:
    """A component's node: the node under its own name `own` (a fully qualified name) if it runs,
    is not `claimed`, declares no other component and is not finalized; else the one node of own's
    namespace whose status declares the component (`declared`), a new version's `X_2`
    (docs/executor.md#names)."""
    claimed = set(claimed)
    # a node whose status says it is finalized is gone, though its process (others' too) still runs
    graph = {f for f in graph if statuses.get(f, {}).get("lifecycle") != "finalized"}
    if own in graph and own not in claimed and statuses.get(own, {}).get("component", declared) == declared:
        return own
    ns = own.rsplit("/", 1)[0]
    found = [f for f, st in statuses.items() if st.get("component") == declared and f in graph
             and f.rsplit("/", 1)[0] == ns and f not in claimed]
    return found[0] if len(found) == 1 else None


# --- reconf_ros/executor/remote.py ---

AGENT_PORT = 7411            # the agent's default TCP port
LOCAL = "local"              # a hosts file's value for this machine: no agent
MAX_WAIT = 20.0              # s an agent waits for an exit in one request


class HostError(OSError):
    """A host's agent failed a request: the message names the host and why; `host` is its name."""

    def __init__(self, host: str, message: str) -> None:
        super().__init__(message)
        self.host = host

    def __str__(self) -> str:
        return str(self.args[0])


class HostUnreachable(HostError):
    """A host's agent could not be reached, or broke off."""


class HostRefused(HostError):
    """A host's agent answered a request with a refusal (its reason in the message)."""


def proof(token: bytes, role: str, challenge: str) -> str:
    """What a side ("client" or "agent") sends to show it holds `token`."""
    return hmac.new(token, f"{role}:{challenge}".encode(), hashlib.sha256).hexdigest()


def read_hosts(path: str) -> tuple[dict[str, str], bytes]:
    """A hosts file: host -> "ADDRESS:PORT" (or "local"), and the agents' token. Raises
    ValueError with what is wrong, OSError when a file cannot be read."""
    with open(path, encoding="utf-8") as fh:
        doc = json.load(fh)
    hosts = doc.get("hosts") if isinstance(doc, dict) else None
    if not isinstance(hosts, dict) or not all(isinstance(v, str) for v in hosts.values()):
        raise ValueError(f"{path}: not a hosts file (want {{\"hosts\": {{\"NAME\": \"ADDRESS:PORT\"}}, "
                         "\"token_file\": \"FILE\"}})")
    token = b""
    if any(v != LOCAL for v in hosts.values()):
        name = doc.get("token_file")
        if not isinstance(name, str):
            raise ValueError(f"{path}: a hosts file with agents names their token_file")
        with open(os.path.join(os.path.dirname(os.path.abspath(path)), name), "rb") as fh:
            token = fh.read().strip()
        if not token:
            raise ValueError(f"{path}: the token file {name} is empty")
    return {str(k): str(v) for k, v in hosts.items()}, token


class Agent:
    """One host's agent, over one connection made on first use (and again once if it breaks)."""

    def __init__(self, host: str, address: str, token: bytes, timeout: float) -> None:
        self.host, self.address, self.token, self.timeout = host, address, token, timeout
        self.sock: Optional[socket.socket] = None
        self.stream: Any = None
        self.lock = threading.Lock()     # one request at a time on the connection (a batch's steps share it)

    def where(self) -> str:
        return f"host {self.host} ({self.address})"

    def _connect(self) -> None:
        addr, _, port = self.address.rpartition(":")
        try:
            sock = socket.create_connection((addr or self.address, int(port or AGENT_PORT)), timeout=self.timeout)
        except (OSError, ValueError) as e:
            raise HostUnreachable(self.host, f"{self.where()} cannot be reached: {getattr(e, 'strerror', None) or e}") from None
        self.sock, self.stream = sock, sock.makefile("rwb")
        hello = self._read()
        if hello.get("agent") != self.host:
            self.close()
            raise HostUnreachable(self.host, f"{self.where()}: the agent there is host {hello.get('agent')!r}'s")
        mine = secrets.token_hex(16)
        self._write({"proof": proof(self.token, "client", str(hello.get("challenge"))), "challenge": mine})
        answer = self._read()
        if not hmac.compare_digest(str(answer.get("proof", "")), proof(self.token, "agent", mine)):
            self.close()
            raise HostUnreachable(self.host, f"{self.where()}: the agent refused the token, or does not hold it "
                                  f"({answer.get('error', 'no proof')})")

    def _write(self, doc: dict[str, Any]) -> None:
        self.stream.write(json.dumps(doc).encode() + b"\n")
        self.stream.flush()

    def _read(self) -> dict[str, Any]:
        line = self.stream.readline()
        if not line:
            raise ConnectionResetError("the connection closed")
        doc = json.loads(line)
        if not isinstance(doc, dict):
            raise ValueError(f"not an answer: {line[:200]!r}")
        return doc

    def request(self, doc: dict[str, Any], wait: float = 0.0) -> dict[str, Any]:
        """Send one request and return its answer (a refusal raises OSError with the reason);
        `wait`: how much longer than the timeout the agent may take (a wait for an exit)."""
        with self.lock:
            return self._request(doc, wait)

    def _request(self, doc: dict[str, Any], wait: float) -> dict[str, Any]:
        for attempt in (1, 2):
            try:
                if self.sock is None:
                    self._connect()
                assert self.sock is not None
                self.sock.settimeout(self.timeout + wait)
                self._write(doc)
                answer = self._read()
                break
            except HostUnreachable:
                raise
            except (OSError, ValueError) as e:
                self.close()
                if attempt == 2 or doc.get("op") == "start":    # a start is never sent twice
                    raise HostUnreachable(self.host, f"{self.where()} broke off: {getattr(e, 'strerror', None) or e}") from None
        if "error" in answer:
            raise HostRefused(self.host, f"{self.where()} refused: {answer['error']}")
        return answer

    def close(self) -> None:
        for part in (self.stream, self.sock):
            try:
                if part is not None:
                    part.close()
            except OSError:
                pass
        self.sock = self.stream = None


class RemoteProcess:
    """A process an agent started on its host: what an executor needs of a `subprocess.Popen`."""

    def __init__(self, agent: Agent, pid: int, log: str, how: str = "") -> None:
        self.agent, self.pid, self.log, self.how = agent, pid, log, how
        self.returncode: Optional[int] = None

    def poll(self) -> Optional[int]:
        if self.returncode is None:
            status = self.agent.request({"op": "poll", "pid": self.pid}).get("status")
            self.returncode = None if status is None else int(status)
        return self.returncode

    def wait(self, timeout: Optional[float] = None) -> int:
        end = None if timeout is None else time.monotonic() + timeout
        while self.returncode is None:
            left = MAX_WAIT if end is None else end - time.monotonic()
            if left <= 0:
                raise subprocess.TimeoutExpired(f"pid {self.pid} on {self.agent.where()}", timeout or 0.0)
            chunk = min(left, MAX_WAIT)
            status = self.agent.request({"op": "wait", "pid": self.pid, "timeout": chunk}, wait=chunk).get("status")
            self.returncode = None if status is None else int(status)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.returncode is None:
            status = self.agent.request({"op": "signal", "pid": self.pid, "signal": int(sig)}).get("status")
            self.returncode = None if status is None else int(status)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)

    def tail(self, size: int = 2000) -> str:
        """The end of its log, read on its host."""
        return str(self.agent.request({"op": "tail", "pid": self.pid, "bytes": size}).get("text", ""))


class Hosts:
    """The agents a hosts file names (`read_hosts`), each reached on first use. A host the file
    does not name fails, naming the host and the file: a component is never started elsewhere
    than where its architecture places it."""

    def __init__(self, path: str, timeout: float) -> None:
        self.path, self.timeout = path, timeout
        self.where, self.token = read_hosts(path)
        self.agents: dict[str, Agent] = {}

    def agent(self, host: Optional[str]) -> Optional[Agent]:
        """The agent of `host`; None for this machine (no host, or the file's "local")."""
        if not host:
            return None
        address = self.where.get(host)
        if address is None:
            raise HostError(host, f"host {host} is not in the hosts file {self.path} (it names "
                          f"{', '.join(sorted(self.where)) or 'no host'})")
        if address == LOCAL:
            return None
        return self.agents.setdefault(host, Agent(host, address, self.token, self.timeout))

    def start(self, agent: Agent, argv: list[str], log: str, env: dict[str, str],
              files: Optional[dict[str, str]] = None) -> RemoteProcess:
        """Start `argv` on the agent's host: its log `log` (a relative name) in the agent's log
        directory, `env` added to the agent's environment (with this process's ROS domain, which
        the nodes must share), `files` (relative name -> text) written there first, and an
        argument naming one of them given its path there."""
        env = {"ROS_DOMAIN_ID": os.environ.get("ROS_DOMAIN_ID", "0"), **env}
        answer = agent.request({"op": "start", "argv": argv, "log": log, "env": env, "files": files or {}})
        return RemoteProcess(agent, int(answer["pid"]), str(answer["log"]), str(answer.get("how", "")))

    def close(self) -> None:
        for agent in self.agents.values():
            agent.close()


# --- reconf_ros/executor/runtime.py ---

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


# --- reconf_ros/executor/naming.py ---

class Names:
    """The node of each component of one plan: its own name, or where `locate` found it or a
    create put it (`placed`)."""

    def __init__(self, rt: Any, renames: dict[str, str], components: Iterable[str], fingerprint: str) -> None:
        self.rt, self.renames, self.fingerprint = rt, renames, fingerprint
        self.components = set(components)
        self.placed: dict[str, str] = {}        # component -> its node's name, where not its own

    def declared(self, comp: str) -> str:
        """The component's name in its architecture, which its node declares in its status."""
        return self.renames.get(comp, comp)

    def is_version(self, comp: str) -> bool:
        """A new version `X@new` of a component X of the same plan (docs/executor.md#names)."""
        return comp in self.renames and self.renames[comp] in self.components

    def node_name(self, comp: str) -> str:
        """The component's node's name: its own, or where `locate` found it or a create put it;
        a new version not yet found, or a component whose name a new version's node has, has
        none ("X@new" and "X@elsewhere" are never a node's name)."""
        return self.placed.get(comp) or (comp if self.is_version(comp) else self.declared(comp))

    def fqn(self, comp: str) -> str:
        return f"{self.rt.namespace}/{self.node_name(comp)}"

    def connector(self, conn: str) -> str:
        """A connector's name on the wire (a new version's is its name in the new architecture)."""
        return self.renames.get(conn, conn)

    def created_mark(self, comp: str) -> str:
        """What a process a plan's create started shows as `created` in its status."""
        return f"{self.fingerprint} {comp}"

    def locate(self, comps: Iterable[str], graph: Optional[set[str]] = None) -> None:
        """Find the nodes not under their components' names, by their statuses: a new version by
        the mark of the plan step that started it, any other component by the component its
        node declares (a node a plan started as `X@new` declares X and runs on as X). `graph`:
        the nodes, when the caller has just read them."""
        graph, ns = (set(self.rt.nodes()) if graph is None else graph), self.rt.namespace
        mine = {st.get("created", ""): fqn for fqn, st in self.rt.statuses.items() if fqn in graph}
        claimed = {f"{ns}/{n}" for n in self.placed.values()} | \
            {mine[self.created_mark(c)] for c in self.components if self.is_version(c) and self.created_mark(c) in mine}
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

    def fresh(self, comp: str) -> str:
        """A node name for a new version: its component's name if no node has it, else the first
        free `<name>_<k>`."""
        base, ns = self.declared(comp), self.rt.namespace
        taken = set(self.rt.nodes()) | {f"{ns}/{n}" for n in self.placed.values()}
        k, name = 2, base
        while f"{ns}/{name}" in taken:
            name, k = f"{base}_{k}", k + 1
        return name


# --- reconf_ros/executor/context.py ---

class Writer(Protocol):
    """Where a run's words go: a text stream, or a manager's stream to its client."""

    def write(self, text: str, /) -> int: ...

    def flush(self) -> None: ...


@dataclass
class Started:
    """A process this run started for a component's create."""
    pid: int
    log: str
    command: str
    node: str
    proc: Any                        # its subprocess.Popen, the launcher's handle, or an agent's RemoteProcess
    ended: Optional[int] = None      # its exit status, once a remove has waited for it
    host: str = ""                   # the host whose agent started it ("": this machine; its pid and log are there)
    held: Optional[float] = None     # s it was held before its step, if forked ahead (docs/executor.md#held)
    how: str = ""                    # how it was started, for the step's line

    def to_doc(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"pid": self.pid, "log": self.log, "command": self.command, "node": self.node}
        doc.update({"host": self.host} if self.host else {})
        doc.update({"held_s": round(self.held, 3)} if self.held is not None else {})
        return doc if self.ended is None else {**doc, "ended": self.ended}


@dataclass
class Held:
    """A node process forked ahead of its create and held before it makes its node
    (docs/executor.md#held)."""
    proc: Any                        # the launcher's handle
    argv: list[str]
    log: str
    at: float                        # when it was forked (monotonic)


@dataclass
class StepTiming:
    """When a step began (wall clock, for the report) and how long it took."""
    step: int
    at: float
    seconds: float
    ok: bool
    action: str = ""

    def to_doc(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"step": self.step, "at": self.at, "seconds": self.seconds, "ok": self.ok}
        return {**doc, "action": self.action} if self.ok else doc


class Interrupts:
    """SIGINT and SIGTERM as a run takes them (docs/executor.md#interrupted): the first asks the
    run to stop at the end of the current step, the second (and any later one) stops it at once
    (KeyboardInterrupt, where Python is when it comes). A manager also counts the stop requests
    its client forwards (`poll`: a call that returns who asked, or "")."""

    def __init__(self) -> None:
        self.count = 0                 # stops asked: signals and forwarded requests
        self.signals = 0               # signals this process received
        self.by = ""                   # who asked first
        self.poll: Optional[Callable[[], str]] = None

    def handler(self, signum: int, frame: Any) -> None:
        self.signals += 1
        self.ask(signal.Signals(signum).name)
        if self.count > 1:
            raise KeyboardInterrupt

    def ask(self, by: str) -> None:
        self.count += 1
        self.by = self.by or by

    def install(self) -> None:
        """Take SIGINT and SIGTERM (in the main thread)."""
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self.handler)

    def forget_requests(self) -> None:
        """After a manager's run: only this process's own signals still count."""
        self.count, self.poll = self.signals, None
        self.by = self.by if self.signals else ""

    @property
    def stop(self) -> bool:
        asked = self.poll() if self.poll is not None else ""
        if asked:
            self.ask(asked)
        return self.count > 0


@dataclass
class Context:
    """One run of a plan document on the live system."""
    doc: dict[str, Any]
    args: argparse.Namespace
    out: Writer
    err: Writer
    rt: Any = None                   # the Runtime, once the run has one
    launcher: Any = None             # a manager's fork server (docs/executor.md#launcher)
    started: dict[str, Started] = field(default_factory=dict)
    touched: set[str] = field(default_factory=set)
    timings: list[StepTiming] = field(default_factory=list)
    failure: str = ""                # why the last step failed
    interrupts: Interrupts = field(default_factory=Interrupts)
    step: int = 0                    # the step being performed (0: none yet)
    began: float = 0.0               # when it began, on the wall clock (what the nodes' statuses use)
    baseline: dict[str, int] = field(default_factory=dict)    # each counted monitor's violations at its start
    violated: dict[str, int] = field(default_factory=dict)    # a monitor whose count moved -> the step it was seen after
    violations: dict[str, int] = field(default_factory=dict)  # such a monitor -> how many it saw, at the last count
    last_violation: dict[str, str] = field(default_factory=dict)  # such a monitor -> its status's `last_violation`
    unread: set[str] = field(default_factory=set)     # components whose node did not answer the last reading
    read_at: Optional[float] = None  # when the last reading of the nodes began, on the wall clock
    failed_host: str = ""            # the host whose agent failed the last step (docs/hosts.md)
    # removed components this run saw end: finalized at their remove, or their process exited;
    # absent from then on, and not asked again (a finalized node cannot come back)
    ended: set[str] = field(default_factory=set)
    gaps: dict[str, float] = field(default_factory=dict)   # "comp.port" -> its largest input gap before the first step
    held: dict[str, Held] = field(default_factory=dict)    # component -> its process, forked ahead and held
    holding: Any = None              # the thread that forks them (`processes.hold`), while it runs
    hold_stop: threading.Event = field(default_factory=threading.Event)     # it stops forking

    def __post_init__(self) -> None:
        self.model = Model(self.doc["model"])
        self.steps: list[Step] = plan_steps(self.doc)
        # steps performed together; one at a time with --one-at-a-time (docs/executor.md#batches)
        self.batches: list[tuple[int, int]] = [] if getattr(self.args, "one_at_a_time", False) else batches(self.doc)
        self.states = PlanStates(self.doc["plan"])
        self.runs: dict[str, Optional[str]] = {c["name"]: c.get("run") for c in self.doc["model"]["components"]}
        self.log_dir: str = self.args.log_dir or os.path.join(
            "reconf-logs", f"{self.doc['system']}-{datetime.datetime.now().strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")
        self._names: Optional[Names] = None
        recovery = self.doc["plan"].get("recovery") or {}
        self.placed: dict[str, str] = dict(recovery.get("placed") or {})
        self.orphans: list[dict[str, Any]] = list(recovery.get("orphans") or [])
        hosts_file = getattr(self.args, "hosts", "")
        # the agents of the hosts file (--hosts): each reached on first use
        self.hosts: Optional[Hosts] = Hosts(hosts_file, self.args.timeout) if hosts_file else None

    @property
    def names(self) -> Names:
        """The components' nodes (made with the runtime, which knows the namespace and the graph)."""
        if self._names is None:
            self._names = Names(self.rt, self.doc["plan"].get("renames", {}), self.model.comps,
                                self.doc["fingerprint"])
            self._names.placed.update(self.placed)     # where a recovery found the nodes
        return self._names

    def say(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    def warn(self, text: str) -> None:
        print(text, file=self.err, flush=True)


# --- reconf_ros/executor/replay.py ---

def _walk(model: Model, steps: list[Step], recorded: PlanStates,
          out: Writer) -> tuple[list[tuple[str, State]], Optional[tuple[int, Step, str]], bool]:
    """Every state the steps reach, labelled; the first step refused, if one is; whether each
    state is the one the document records."""
    state = recorded[0] if recorded else State([], [], [])
    rows, agree = [("  0.   initial state", state)], True
    for i, step in enumerate(steps, 1):
        why = model.refusal(state, step)
        if why:
            return rows, (i, step, why), agree
        state = model.effect(state, step)
        if i < len(recorded) and recorded[i].key() != state.key():
            print(f"dry run: after step {i} the embedded plan records a different state than the steps give",
                  file=out)
            agree = False
        rows.append((step.label(i), state))
    return rows, None, agree


def _verdict(model: Model, steps: list[Step], restore: int, i: int, st: State) -> tuple[str, list[str]]:
    """`safe`, `UNSAFE`, or `restoring`: a state before the end of a recovery's first degrades
    that fails only on functionalities a later one of them degrades (docs/soundness.md#restoring-validity)."""
    bad = model.failing(st)
    if not bad:
        return "safe", []
    words = [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in bad]
    later = {(s.component, s.functionality) for s in steps[i:restore] if s.action == "degrade"}
    if i < restore and all((c, f) in later for c, f, _ in bad):
        return "restoring", words
    return "UNSAFE", words


def replay(doc: dict[str, Any], out: Writer) -> bool:
    """Replay the plan from its first state; print every state; True when all are safe (or, in a
    recovery's first degrades, restoring validity)."""
    model, steps, restore = Model(doc["model"]), plan_steps(doc), restoring(doc)
    rows, refused, ok = _walk(model, steps, PlanStates(doc["plan"]), out)
    unsafe = []
    for i, (text, st) in enumerate(rows):
        verdict, bad = _verdict(model, steps, restore, i, st)
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(st.degraded) if c in st.components) or "-"
        print(f"{text:<60} [{verdict}]  degraded: {degraded}", file=out)
        for reason in bad:
            print(f"       {reason}", file=out)
        if verdict == "UNSAFE":
            unsafe.append(i)
    if refused is not None:
        i, step, why = refused
        print(f"{step.label(i):<60} [REFUSED]  {why}", file=out)
        print(f"dry run: step {i} ({step.describe()}) cannot run: {why}", file=out)
        ok = False
    if unsafe:
        where = ", ".join(f"step {i} ({steps[i - 1].describe()})" if i else "the initial state" for i in unsafe)
        print(f"dry run: UNSAFE after {where}", file=out)
        ok = False
    if ok and restore:
        print(f"dry run: steps 1-{restore} restore validity; " if restore > 1 else
              "dry run: step 1 restores validity; ", end="", file=out)
        print(f"the {len(rows) - restore} states from there are safe" if len(rows) - restore != 1 else
              "the 1 state from there is safe", file=out)
    elif ok:
        print("dry run: " + (f"all {len(rows)} states are safe" if len(rows) != 1 else "the 1 state is safe"),
              file=out)
    return ok


# --- reconf_ros/executor/observe.py ---

@dataclass
class Observed:
    """What the executor saw of one component's node: `lifecycle` is its state's label,
    `absent` (not in the graph, or finalized), `unresponsive` (in the graph, not answering) or
    `not a reconf node` (answering, without the lifecycle services, or without this component's
    parameters: a node of another version of it, or no reconf node)."""
    comp: str
    lifecycle: str
    modes: dict[str, str] = field(default_factory=dict)
    ports: dict[str, list[str]] = field(default_factory=dict)
    why: str = ""                   # what the node answered, when that is why it is not the component

    @property
    def present(self) -> bool:
        return self.lifecycle == "active"


def _control_parameters(ctx: Context, comp: str) -> list[str]:
    info = ctx.model.comps[comp]
    return [f"reconf.mode.{f['name']}" for f in info["functionalities"]] + \
        [f"reconf.port.{p['name']}" for p in info["ports"]]


def observe(ctx: Context, comps: Iterable[str]) -> dict[str, Observed]:
    """Read each component's node: lifecycle state, modes, attachments; every node at once.
    `ctx.read_at` is when the reading began (what happens to a node after may not be in it)."""
    ctx.read_at = round(time.time(), 3)
    comps, names = sorted(comps), ctx.names
    graph = set(ctx.rt.nodes())
    names.locate(comps, graph)
    # a node this run saw finalized, or whose process exited, may stay in the graph a while (on
    # another host, seconds): it is absent, and asking it would wait for the timeout
    seen = {c: Observed(c, "absent") for c in comps if names.fqn(c) not in graph or c in ctx.ended}
    # the lifecycle state and the parameters of each at once; the parameters of an active one read
    states, params = ctx.rt.read({names.fqn(c): _control_parameters(ctx, c) for c in comps if c not in seen})
    active = set()
    for c in comps:
        lc = states.get(names.fqn(c))
        if c in seen or lc is None:
            continue
        if isinstance(lc, StepFailed):    # in the graph, but not answering: say so, do not guess
            seen[c] = Observed(c, "not a reconf node") if isinstance(lc, NoControlInterface) else _silent(ctx, c)
        elif lc != "active":
            seen[c] = Observed(c, "absent" if lc == "finalized" else lc)
        else:
            active.add(c)
    for c in comps:
        values = params.get(names.fqn(c))
        if c not in active or values is None:
            continue
        if isinstance(values, NoControlInterface):  # it answered, without the parameters of this
            seen[c] = Observed(c, "not a reconf node", why=str(values))  # component (another version?)
            continue
        if isinstance(values, StepFailed):    # it answered get_state, then not: say so, do not guess
            seen[c] = _silent(ctx, c, str(values))
            continue
        modes = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.mode.")}
        ports = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.port.")}
        seen[c] = Observed(c, "active", modes, ports)
    return dict(sorted(seen.items()))


def _silent(ctx: Context, comp: str, why: str = "") -> Observed:
    """A node in the graph that did not answer: absent if the process this run started for it
    has exited, else unresponsive, never guessed at."""
    return Observed(comp, "absent" if _exited(ctx, comp) else "unresponsive", why=why)


def _exited(ctx: Context, comp: str) -> bool:
    """Whether the process this run started for `comp` has exited, or this run saw the component
    end at its remove (a node gone stays in the graph a while, not answering: it is absent, not
    unknown)."""
    info = ctx.started.get(comp)
    return comp in ctx.ended or (info is not None and info.proc.poll() is not None)


def as_state(ctx: Context, seen: dict[str, Observed]) -> State:
    """The configuration the nodes showed: the active ones present, their modes and attachments."""
    back = {v: k for k, v in ctx.names.renames.items()}
    comps = [c for c, o in seen.items() if o.present]
    degraded = [(c, f) for c in comps for f, m in seen[c].modes.items() if m != "normal"]
    roles = [(back.get(k, k), c, p) for c in comps for p, ks in seen[c].ports.items() for k in ks]
    return State(comps, degraded, roles)


def read_all(ctx: Context) -> tuple[State, dict[str, Observed]]:
    """Every component of the model read: the configuration, and what each node showed (the
    components whose node did not answer noted in `ctx.unread`: the configuration says
    nothing of them)."""
    seen = observe(ctx, ctx.model.comps)
    ctx.unread = {c for c, o in seen.items() if o.lifecycle == "unresponsive"}
    return as_state(ctx, seen), seen


def neighbourhood(ctx: Context) -> set[str]:
    """The components the plan touches, and those attached to a connector it touches."""
    comps = {s.component for s in ctx.steps}
    conns = {s.connector for s in ctx.steps if s.connector}
    for st in ctx.states:
        conns |= {n for n, c, p in st.roles if c in comps}
    for st in ctx.states:
        comps |= {c for n, c, p in st.roles if n in conns}
    return comps & set(ctx.model.comps)


def settle(ctx: Context, expected: Iterable[str], seconds: float) -> None:
    """Let discovery catch up before reading the graph (bounded by `seconds`): every node the
    plan expects running seen, one announcement period passed, and the graph unchanged for a
    while. A node the plan expects absent but that runs must not be missed (a re-run would
    start a second one)."""
    expected = set(expected)

    def want(nodes: set[str]) -> set[str]:
        ctx.names.locate(expected, nodes)
        return {ctx.names.fqn(c) for c in expected}
    ctx.rt.wait(lambda: ctx.rt.settled(want), seconds)


def wait_status(ctx: Context, comp: str, cond: Callable[[Status], bool], seconds: float) -> bool:
    """Wait (bounded) until the component's node shows a status that meets `cond`."""
    return ctx.rt.wait(lambda: (st := ctx.rt.status(ctx.names.fqn(comp))) is not None and cond(st), seconds)


def wait_statuses(ctx: Context, comps: Iterable[str]) -> None:
    """Wait (bounded) for a status from each running component, so violations can be counted."""
    want = list(comps)
    ctx.rt.wait(lambda: all(ctx.rt.status(ctx.names.fqn(c)) is not None for c in want), 3.0)


def violations(ctx: Context, comps: Iterable[str]) -> dict[str, int]:
    """Each heard-from component's monitor's count of normal-mode assumptions violated."""
    out = {}
    for c in comps:
        st = ctx.rt.status(ctx.names.fqn(c))
        if st is not None:
            out[c] = int(st.get("violations", "0"))
    return out


def last_violations(ctx: Context, comps: Iterable[str]) -> dict[str, str]:
    """Each heard-from component's monitor's last violation, as its status says it (when it began on
    the wall clock, the functionality, why), if it saw any."""
    out = {}
    for c in comps:
        last = (ctx.rt.status(ctx.names.fqn(c)) or {}).get("last_violation")
        if last:
            out[c] = last
    return out


def largest_gaps(ctx: Context, comps: Iterable[str]) -> dict[str, float]:
    """Each heard-from monitored input's largest wait for data since its node started
    (`in.<port>.max_gap_s` of its status, docs/control-interface.md): "component.port" -> s."""
    out = {}
    for c in comps:
        for key, value in (ctx.rt.status(ctx.names.fqn(c)) or {}).items():
            if key.startswith("in.") and key.endswith(".max_gap_s"):
                out[f"{c}.{key[3:-len('.max_gap_s')]}"] = float(value)
    return out


def check_touched(ctx: Context, expected: State, when: str) -> None:
    """Every component the plan has touched reads back as `expected` has it."""
    # a node that answered its services may not be in this node's graph yet, nor heard on
    # /diagnostics: under load, discovery lags behind the services by seconds
    want = {ctx.names.fqn(c) for c in ctx.touched & expected.components}
    ctx.rt.wait(lambda: want <= set(ctx.rt.nodes()), ctx.args.discovery_timeout)
    seen = observe(ctx, ctx.touched)
    diffs = ctx.model.differences(expected, as_state(ctx, seen), ctx.touched)
    if diffs:
        raise StepFailed(f"{when}: " + "; ".join(diffs + [o.why for _, o in sorted(seen.items()) if o.why]))


def unusual(ctx: Context, seen: dict[str, Observed]) -> None:
    """Say which nodes are neither absent nor active (inactive, unresponsive, …)."""
    for c, o in sorted(seen.items()):
        if o.lifecycle not in ("absent", "active"):
            ctx.warn(f"    ({c} is {o.lifecycle}: not counted as present{': ' + o.why if o.why else ''})")


# --- reconf_ros/executor/conditions.py ---

def meets(func: str) -> Callable[[Status], bool]:
    """Whether a status shows `func`'s normal assumptions met on the wire (or not observed)."""
    return lambda st: st.get(f"wire.{func}", "").split(":")[0] in ("met", "unobserved")


def on_demand(ctx: Context, comp: str, port: str) -> bool:
    """Whether data reaches `comp.port` only when asked for (an FTM's requests and results,
    its status says; or its assumption has no rate): no data may flow while a step runs."""
    st = ctx.rt.status(ctx.names.fqn(comp)) or {}
    declared = ctx.model.port(comp, port)
    return st.get(f"in.{port}.on_demand") == "1" or rate(declared["assumption"] if declared else None) is None


def publishes(ctx: Context, comp: str, port: str, state: State) -> bool:
    """Whether `comp.port`'s functionality guarantees data at a rate there in `state`'s mode
    (data without a rate comes on demand: an FTM's requests, say; matching is all there is
    to wait for)."""
    for f in ctx.model.comps[comp]["functionalities"]:
        if port in f["ports"]:
            g = ctx.model.guarantee(ctx.model.mode(comp, f, state), port)
            if g is not None and g.get("message") is not None and g.get("hz") is not None:
                return True
    return False


def _ends(ctx: Context, conn: str, state: State, kind: str) -> list[tuple[str, str]]:
    """The present (component, port) pairs of `kind` ("input", "output") attached to `conn`."""
    return [(c, p) for n, c, p in sorted(state.roles)
            if n == conn and c in state.components and ctx.model.port_kind(c, p) == kind]


def wire_before(ctx: Context, step: Step, was: State, will: State) -> None:
    """What the wire must show before the step: an upgraded functionality's assumptions met;
    a connector that loses a publisher still delivering from the ones that remain."""
    if step.action == "upgrade":
        _assumptions_hold(ctx, step)
    for conn in ctx.model.conns:
        kept = ctx.model.satisfying(will, conn)
        if kept and not set(kept) >= set(ctx.model.satisfying(was, conn)):
            _readers_keep_data(ctx, step, conn, kept, was, will)


def _assumptions_hold(ctx: Context, step: Step) -> None:
    """The upgraded functionality's assumptions met, in a status that shows each input it relies
    on at a rate received since the step began: a verdict of "met" can be a silence old, since a
    node calls a silence a gap only when its timer next looks (after up to twice the limit)."""
    comp, f = step.component, step.functionality
    fed = _rated_inputs(ctx, comp, f)
    _ask(ctx, [(comp, p) for p in fed])
    if wait_status(ctx, comp, lambda st: meets(f)(st) and all(_heard_since(st, p, ctx.began) for p in fed),
                   ctx.args.wire_timeout):
        return
    st = ctx.rt.status(ctx.names.fqn(comp)) or {}
    silent = [p for p in fed if not _heard_since(st, p, ctx.began)]
    raise StepFailed(f"{comp}.{f}: its assumptions are not met on the wire "
                     f"({st.get(f'wire.{f}', 'no status from the node')})" + (
                         f"; nothing received on {', '.join(silent)} since the step began" if st and silent else ""))


def _rated_inputs(ctx: Context, comp: str, func: str) -> list[str]:
    """The inputs `comp`'s functionality `func` relies on in its normal mode for data at a rate
    (not an FTM's requests and results, which come on demand)."""
    return sorted({p for f in ctx.model.comps[comp]["functionalities"] if f["name"] == func
                   for p, a in ctx.model.relied_on(comp, f) if rate(a) is not None and not on_demand(ctx, comp, p)})


def _ask(ctx: Context, inputs: list[tuple[str, str]]) -> None:
    """Ask the nodes of these (component, input) pairs for the status that shows a reception
    since the step began (docs/control-interface.md#asked-status)."""
    if inputs:
        ctx.rt.ask(ctx.began, [(ctx.names.fqn(c), p) for c, p in inputs])


def _readers_keep_data(ctx: Context, step: Step, conn: str, kept: list[str], was: State, will: State) -> None:
    """Every reader relying on `conn` receives from a publisher that stays (`kept`); a reader of
    data on demand is matched with every publisher it had, the ones that stay among them."""
    names = {ctx.names.node_name(c) for c in kept}
    k, wait = ctx.names.connector(conn), ctx.args.wire_timeout
    matched = len(_ends(ctx, conn, was, "output"))
    readers = [(r, p) for r, p in _ends(ctx, conn, will, "input") if p in ctx.model.relying_inputs(r, will)]
    fed = [(r, p) for r, p in readers if not on_demand(ctx, r, p)]
    _ask(ctx, fed)
    for reader, port in readers:
        key = f"in.{port}@{k}.publishers"
        if (reader, port) not in fed:
            # data on demand (an FTM's requests): none may flow now
            if not wait_status(ctx, reader, lambda st: int(st.get(key, "0")) >= matched, wait):
                st = ctx.rt.status(ctx.names.fqn(reader)) or {}
                raise StepFailed(f"{reader}.{port} is matched with {st.get(key, 'no')} of the "
                                 f"{plural(matched, 'publisher')} of {k}; taking {step.component}'s away "
                                 "could leave it without one")
        elif not wait_status(ctx, reader, lambda st: bool(_heard_since(st, port, ctx.began, names)), wait):
            st = ctx.rt.status(ctx.names.fqn(reader)) or {}
            raise StepFailed(f"{reader}.{port} has received nothing on {k} from {', '.join(sorted(names))} since the "
                             f"step began (fresh sources: {st.get(f'in.{port}.fresh') or 'none'}); taking "
                             f"{step.component}'s away would leave it without data")


def _heard_since(st: Status, port: str, since: float, nodes: Optional[set[str]] = None) -> list[str]:
    """The nodes (of `nodes`, or any) whose messages `port` received after `since` (wall clock),
    as the status shows: a publisher that died a moment ago vouches for nothing with what it sent
    before."""
    head = f"in.{port}.last."
    return sorted(k[len(head):] for k, v in st.items()
                  if k.startswith(head) and float(v or 0) > since and (nodes is None or k[len(head):] in nodes))


def wire_after(ctx: Context, step: Step, will: State) -> None:
    """An attached port is matched with the other side of its connector as the plan has it; an
    attached output that publishes is heard by every subscriber; a degraded functionality that
    reports what it has in flight has none left (`drained`)."""
    if step.action == "degrade":
        return drained(ctx, step)
    if step.action != "attach":
        return
    comp, port, conn = step.component, step.port, step.connector
    k, wait = ctx.names.connector(conn), ctx.args.wire_timeout
    pubs, subs = _ends(ctx, conn, will, "output"), _ends(ctx, conn, will, "input")
    kind = ctx.model.port_kind(comp, port)
    if kind == "output" and subs:
        key = f"out.{port}@{k}.subscribers"
        if not wait_status(ctx, comp, lambda st: int(st.get(key, "0")) >= len(subs), wait):
            raise StepFailed(f"{comp}.{port} is not matched with the {plural(len(subs), 'subscriber')} of {k} "
                             f"within {wait} s")
    for c, p in (subs if kind == "output" else [(comp, port)]):
        key = f"in.{p}@{k}.publishers"
        if pubs and not wait_status(ctx, c, lambda st: int(st.get(key, "0")) >= len(pubs), wait):
            raise StepFailed(f"{c}.{p} is not matched with the {plural(len(pubs), 'publisher')} of {k} "
                             f"within {wait} s")
    if kind == "output" and publishes(ctx, comp, port, will):
        # Matched counts can be stale (a publisher just gone still counted): the data decides.
        me = f"in.{{}}.from.{ctx.names.node_name(comp)}"
        for c, p in subs:
            if on_demand(ctx, c, p):
                continue            # nothing flows until asked for; matched above
            if not wait_status(ctx, c, lambda st: me.format(p) in st, wait):
                raise StepFailed(f"{c}.{p} has received nothing from {comp} on {k} within {wait} s")


def drained(ctx: Context, step: Step) -> None:
    """After a degrade: a functionality whose status reports `in_flight.<f>` (an FTM protocol:
    the requests inside its layer) shows itself degraded with none in flight. A suspension is
    complete only then: a plan that re-links the layer before would cut a request off inside it
    (docs/control-interface.md#the-six-actions)."""
    comp, f = step.component, step.functionality
    key = f"in_flight.{f}"
    if key not in (ctx.rt.status(ctx.names.fqn(comp)) or {}):
        return
    if not wait_status(ctx, comp, lambda st: st.get(f"mode.{f}") == "degraded" and st.get(key) == "0",
                       ctx.args.wire_timeout):
        st = ctx.rt.status(ctx.names.fqn(comp)) or {}
        raise StepFailed(f"{comp}.{f} still has {st.get(key, 'some')} requests in flight "
                         f"{ctx.args.wire_timeout} s after it was degraded")


# --- reconf_ros/executor/launcher.py ---

__all__ = ["Launcher", "Launched", "launchable", "PROGRAM"]

PROGRAM = "reconf-node"


def launchable(argv: list[str]) -> bool:
    """Whether the launcher can start `argv`: this environment's own `reconf-node`."""
    return bool(argv) and os.path.basename(argv[0]) == PROGRAM and \
        os.path.dirname(os.path.abspath(argv[0])) == os.path.dirname(os.path.abspath(sys.executable))


class Launched:
    """A node the launcher forked: what an executor needs of a `subprocess.Popen`."""

    def __init__(self, launcher: "Launcher", pid: int) -> None:
        self.launcher, self.pid = launcher, pid
        self.returncode: Optional[int] = None

    def poll(self) -> Optional[int]:
        if self.returncode is None:
            self.returncode = self.launcher.status(self.pid)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            try:
                os.kill(self.pid, sig)
            except ProcessLookupError:
                pass

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)

    def wait(self, timeout: Optional[float] = None) -> int:
        end = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if end is not None and time.monotonic() >= end:
                raise subprocess.TimeoutExpired(f"pid {self.pid}", timeout or 0.0)
            time.sleep(0.02)
        assert self.returncode is not None
        return self.returncode


class Launcher:
    """Starts the launcher process and talks to it (from any thread: one request at a time). If it
    is gone, `available` turns false and callers start processes the ordinary way."""

    def __init__(self, timeout: float = 30.0) -> None:
        mine, theirs = socket.socketpair()
        self.proc = subprocess.Popen([sys.executable, "-m", "reconf_ros.tools.launcher", "--fd", str(theirs.fileno())],
                                     pass_fds=[theirs.fileno()], stdin=subprocess.DEVNULL,
                                     preexec_fn=_die_with_parent)
        theirs.close()
        mine.settimeout(timeout)
        self.sock = mine
        self.stream = mine.makefile("rwb")
        self.available = True
        self.statuses: dict[int, int] = {}
        self.unread = 0             # answers to warm requests, read before the next answer
        self.lock = threading.RLock()

    def can_start(self, argv: list[str]) -> bool:
        return self.available and launchable(argv)

    def send(self, req: dict[str, Any]) -> None:
        if not self.available:
            raise OSError("the launcher has stopped")
        try:
            self.stream.write(json.dumps(req).encode() + b"\n")
            self.stream.flush()
        except OSError:
            self.available = False
            raise

    def request(self, req: dict[str, Any]) -> dict[str, Any]:
        with self.lock:
            return self._request(req)

    def _request(self, req: dict[str, Any]) -> dict[str, Any]:
        self.send(req)
        try:
            while self.unread:
                self.stream.readline()
                self.unread -= 1
            line = self.stream.readline()
        except BaseException:       # an answer left unread would be taken for the next one's
            self.available = False
            raise
        if not line:
            self.available = False
            raise OSError(f"the launcher exited (status {self.proc.poll()})")
        answer: dict[str, Any] = json.loads(line)
        if "error" in answer:
            raise OSError(f"the launcher: {answer['error']}")
        return answer

    def warm(self, argv: list[str], cwd: str = "") -> None:
        """Ask the launcher to parse what `argv` reads; the answer is not waited for."""
        with self.lock:
            self.send({"warm": argv, "cwd": cwd or os.getcwd()})
            self.unread += 1

    def start(self, argv: list[str], log: str, cwd: str = "", env: Optional[dict[str, str]] = None,
              hold: bool = False) -> Launched:
        """Fork `argv` with `env` added to the launcher's environment; with `hold`, the child
        initialises ROS and waits for `release` before it makes its nodes (or exits at `cancel`,
        or when the launcher ends, having made none: docs/executor.md#held)."""
        answer = self.request({"start": argv, "log": os.path.abspath(log), "cwd": cwd or os.getcwd(),
                               "env": env or {}, "hold": hold})
        return Launched(self, int(answer["pid"]))

    def release(self, pid: int, names: Optional[dict[str, str]] = None) -> None:
        """Let the held child `pid` make its node, under `names` if given (its component "as", its
        node "node", as `reconf-node --as --node` name them). Raises OSError if it is not held
        (it exited)."""
        self.request({"release": pid, "names": names or {}})

    def cancel(self, pid: int) -> None:
        """End the held child `pid`: it exits having made no node."""
        self.request({"cancel": pid})

    def status(self, pid: int) -> Optional[int]:
        """The exit status of a child that exited, else None (also when the launcher is gone and
        the PID still runs)."""
        if pid in self.statuses:
            return self.statuses[pid]
        try:
            status = self.request({"poll": pid})["status"]
        except OSError:
            try:
                os.kill(pid, 0)
                return None
            except ProcessLookupError:
                status = -1         # gone, status unknown: its parent was the launcher
        if status is not None:
            self.statuses[pid] = int(status)
        return None if status is None else int(status)

    def close(self, wait: bool = True) -> None:
        """Close the socket: the launcher ends (its children stay). With `wait`, wait for it; a
        process about to exit need not (0.15-0.2 s of a plan script's end), as the launcher ends
        with its parent (PR_SET_PDEATHSIG) if it has not yet."""
        try:
            self.stream.close()
            self.sock.close()
        finally:
            if wait:
                try:
                    self.proc.wait(timeout=3)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()


def _die_with_parent() -> None:
    """The launcher ends with the process that started it, a manager, an agent or a plan script (its
    children do not: they are the system's nodes)."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except OSError:
        pass


# --- reconf_ros/executor/processes.py ---

def command(ctx: Context, comp: str, remote: bool = False) -> list[str]:
    """The component's run line, or, when it has none, a model-driven node of the architecture
    the plan reaches (`reconf-node --plan`); with the node's name and namespace. A component
    that is not a reconf node (its `node` block) is started by its adapter, `reconf-node --plan`
    too, which runs the run line itself (docs/adapter.md). `remote`: for an agent on another host,
    which finds the program there; the plan file is then named by `remote_plan` (shipped with the start)."""
    run, names = ctx.runs.get(comp), ctx.names
    adapted = "node" in ctx.model.comps.get(comp, {})
    if adapted and not run:
        raise StepFailed(f"{comp} is a node reconf does not build (its `node` block) and has no run line: "
                         "reconf cannot start it")
    plan = remote_plan(ctx)[0] if remote else ""
    argv = shlex.split(run) if run and not adapted else ["reconf-node", "--plan", plan or plan_path(ctx), comp]
    exe = argv[0] if remote else shutil.which(argv[0]) or shutil.which(argv[0], path=os.path.dirname(sys.executable))
    if exe is None:
        raise StepFailed(f"{argv[0]!r} (the run command of {comp}) is not found")
    argv[0] = exe
    named = comp in names.placed and os.path.basename(exe) == "reconf-node"
    if named:       # the component it is, under the node's own name (rcl's remap rules refuse "__")
        argv[1:1] = ["--as", names.declared(comp), "--node", names.placed[comp]]
    remaps = ([f"__ns:={ctx.rt.namespace}"] if ctx.rt.namespace else []) + \
        ([f"__node:={names.placed[comp]}"] if comp in names.placed and not named else [])
    if remaps:
        argv += ["--ros-args"] if "--ros-args" not in argv else []
        for r in remaps:
            argv += ["-r", r]
    return argv


def _plan_text(ctx: Context) -> tuple[str, str]:
    """The plan document as the nodes read it, and its file's name, named by its content (so a
    log directory shared by several plans gives each node its own plan)."""
    text = json.dumps(ctx.doc, sort_keys=True)
    return f"plan-{hashlib.sha256(text.encode()).hexdigest()[:16]}.json", text


def plan_path(ctx: Context) -> str:
    """The plan document in the log directory, for the nodes that read it."""
    name, text = _plan_text(ctx)
    path = os.path.abspath(os.path.join(ctx.log_dir, name))
    if not os.path.exists(path):
        os.makedirs(ctx.log_dir, exist_ok=True)
        tmp = f"{path}.tmp{os.getpid()}"
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    return path


def run_name(ctx: Context) -> str:
    """This run's directory under an agent's log directory: the last part of the log directory,
    in the characters an agent accepts in a file name."""
    return re.sub(r"[^\w.-]", "_", os.path.basename(os.path.abspath(ctx.log_dir))).lstrip(".") or "run"


def remote_plan(ctx: Context) -> tuple[str, str]:
    """The plan file's name under an agent's log directory, and its text."""
    name, text = _plan_text(ctx)
    return f"{run_name(ctx)}/{name}", text


def start(ctx: Context, argv: list[str], log: str, env: dict[str, str]) -> tuple[Any, str]:
    """Start a node's process, in a session of its own with its own log and `env` added:
    forked by the launcher when there is one and it can, else the ordinary way. Returns the
    process and how it was started, for the step's line."""
    if ctx.launcher is not None and ctx.launcher.can_start(argv):
        try:
            return ctx.launcher.start(argv, log, env=env), " (forked by the launcher)"
        except OSError as e:
            ctx.say(f"      the launcher could not start it ({e}); starting it the ordinary way")
    with open(log, "ab") as fh:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True, env={**os.environ, **env})
    return proc, ""


def host_agent(ctx: Context, comp: str) -> Optional[Agent]:
    """The agent that starts and stops `comp`'s process: None where the process runs on this
    machine (no hosts file, no `host` for the component, or the file's "local"). Raises
    `HostError` (an OSError naming the host) when the hosts file does not name its host: a
    component is never started elsewhere than where its architecture places it."""
    host = ctx.model.comps.get(comp, {}).get("host")
    if ctx.hosts is None or not host:
        return None
    agent: Optional[Agent] = ctx.hosts.agent(host)
    return agent


def on_agent(ctx: Context, comp: str) -> bool:
    """Whether `comp`'s process is an agent's (or its host is not in the hosts file)."""
    host = ctx.model.comps.get(comp, {}).get("host")
    return ctx.hosts is not None and bool(host) and ctx.hosts.where.get(str(host)) != LOCAL


def launch(ctx: Context, comp: str) -> Started:
    """Start `comp`'s process where it runs, with its creation mark in its environment: here
    (a held one released, or `start`), or by its host's agent, which is sent the plan file when
    the node reads it and adds the plan's ROS domain (`Hosts.start`). Returns it (its `how`: how
    it was started, for the step's line). Raises StepFailed, or a `HostError` naming the host
    when its agent cannot be reached or refuses."""
    with _LAUNCHING:
        return _launch(ctx, comp)


# the creates of a batch start their processes one at a time: the plan file, the launcher's
# socket and an agent's connection are each written by one thread (docs/executor.md#batches)
_LAUNCHING = threading.Lock()


def _launch(ctx: Context, comp: str) -> Started:
    agent = host_agent(ctx, comp)
    env, fqn = {CREATED_ENV: ctx.names.created_mark(comp)}, ctx.names.fqn(comp)
    if agent is None or ctx.hosts is None:
        argv = command(ctx, comp)
        log = os.path.join(ctx.log_dir, f"{ctx.names.node_name(comp)}.log")
        held = _release(ctx, comp, argv, log)
        if held is not None:
            ahead = time.monotonic() - held.at
            return Started(held.proc.pid, held.log, shlex.join(argv), fqn, held.proc, held=ahead,
                           how=f" (forked by the launcher {ahead:.2f} s before, held until now)")
        os.makedirs(ctx.log_dir, exist_ok=True)
        proc, how = start(ctx, argv, log, env)
        return Started(proc.pid, log, shlex.join(argv), fqn, proc, how=how)
    argv = command(ctx, comp, remote=True)
    plan, text = remote_plan(ctx)
    files = {plan: text} if plan in argv else {}
    remote = ctx.hosts.start(agent, argv, f"{run_name(ctx)}/{ctx.names.node_name(comp)}.log", env, files)
    return Started(remote.pid, remote.log, shlex.join(argv), fqn, remote, host=agent.host,
                   how=f" on host {agent.host}{remote.how}")


def wait_removed(ctx: Context, comp: str, pid: Optional[int], seconds: float) -> str:
    """After `comp`'s node is finalized, wait up to `seconds` for its process to exit (then
    SIGTERM, then SIGKILL: `wait_exit`): a process this run started, wherever it runs, or, for
    a component on an agent's host, the process its status named (`pid`), by that agent. What
    was seen, for the step's line ("" for a process of this machine another run started, as
    before). Raises `HostError` naming the host when its agent cannot be reached."""
    info = ctx.started.get(comp)
    if info is not None:
        info.ended = wait_exit(info.proc, seconds)
        return f"its process (pid {info.pid}{_on(info.host)}) exited with status {info.ended}" if info.host else ""
    agent = host_agent(ctx, comp)
    if agent is None or pid is None:
        return ""
    try:
        status = wait_exit(RemoteProcess(agent, pid, ""), seconds)
    except HostRefused as e:    # not a process the agent started (one started by hand there)
        return f"its process (pid {pid}) is not host {agent.host}'s agent's, which says: {e}"
    return f"its process (pid {pid} on host {agent.host}) exited with status {status}"


def _end_remote(ctx: Context, fqn: str, comp: str, pid: int) -> Optional[str]:
    """An orphan's process on an agent's host, waited for (and ended) by that agent: its exit
    status as words; None where the component runs on this machine. Raises StepFailed when the
    agent cannot be reached or did not start it (its end is then not known)."""
    try:
        agent = host_agent(ctx, comp)
        if agent is None:
            return None
        return f"exited with status {wait_exit(RemoteProcess(agent, pid, ''), ctx.args.timeout)} on host {agent.host}"
    except HostError as e:
        ctx.failed_host = e.host
        raise StepFailed(f"the orphan {fqn} (pid {pid}): {e}") from None


def _on(host: str) -> str:
    return f" on host {host}" if host else ""


def own_launcher(ctx: Context, first: int, last: int) -> None:
    """Start a launcher of this run's own (a plan script's, not a manager's) when steps `first`..
    `last` create a node this environment's `reconf-node` runs, and `--no-launcher` is not
    given: its imports (about 0.5 s) overlap the wait for discovery, and each create forks from
    it instead of starting a Python from nothing. The run closes it (its children stay)."""
    if ctx.launcher is not None or getattr(ctx.args, "no_launcher", True):
        return
    here = os.path.join(os.path.dirname(sys.executable), PROGRAM)
    for step in ctx.steps[first - 1:last]:
        if step.action != "create" or on_agent(ctx, step.component):
            continue
        run = ctx.runs.get(step.component)       # as `command` reads it (before ROS: no namespace yet)
        program = shlex.split(run)[0] if run and "node" not in ctx.model.comps.get(step.component, {}) else PROGRAM
        if os.path.basename(program) == PROGRAM and os.path.exists(here) and launchable([here]):
            try:
                ctx.launcher = Launcher()
            except OSError as e:
                ctx.say(f"no launcher ({e}): new nodes start the ordinary way")
            return


def forkable(ctx: Context, first: int, last: int) -> list[tuple[str, list[str]]]:
    """The creates of steps `first`..`last` the launcher will start, with their commands: a
    process of this machine whose command is this environment's `reconf-node` (none without a
    launcher)."""
    if ctx.launcher is None:
        return []
    out = []
    for step in ctx.steps[first - 1:last]:
        if step.action != "create" or on_agent(ctx, step.component):
            continue
        try:
            argv = command(ctx, step.component)
        except StepFailed:
            continue                    # the step itself will say so
        if ctx.launcher.can_start(argv):
            out.append((step.component, argv))
    return out


def warm(ctx: Context, forks: list[tuple[str, list[str]]]) -> None:
    """Let the launcher parse what the new nodes `forks` (`forkable`) will read, while the live
    system is checked."""
    for _, argv in forks:
        try:
            ctx.launcher.warm(argv)
        except OSError:
            return                      # the launcher is gone: creates start the ordinary way


def hold(ctx: Context, forks: list[tuple[str, list[str]]]) -> None:
    """Fork ahead, held, the processes of the creates `forks` (`forkable`; not with `--no-hold`):
    in a thread of its own, while the live system is checked. A held process initialises ROS and
    keeps a hidden node of reconf's own, so that by its create its DDS participant has been
    discovered, and it makes its node only when released, under the name its create chose (a
    new version's: docs/executor.md#held)."""
    if not forks or getattr(ctx.args, "no_hold", True):
        return
    os.makedirs(ctx.log_dir, exist_ok=True)
    ctx.holding = threading.Thread(target=_fork_held, args=(ctx, forks), name="hold", daemon=True)
    ctx.holding.start()


HELD_UP_WITHIN = 2.0     # s the next held process waits at most for the last one to be up


def _fork_held(ctx: Context, todo: list[tuple[str, list[str]]]) -> None:
    """Fork each one in turn, the next once the last is up (its hidden node in the graph), or
    released already (its step came first), or after HELD_UP_WITHIN s: one process starting ROS
    at a time, as at the steps, not a burst that starves the running nodes."""
    for comp, argv in todo:
        log = os.path.join(ctx.log_dir, f"{ctx.names.node_name(comp)}.log")
        try:
            proc = ctx.launcher.start(argv, log, env={CREATED_ENV: ctx.names.created_mark(comp)}, hold=True)
        except OSError:
            return                      # the launcher is gone: creates start the ordinary way
        ctx.held[comp] = Held(proc, argv, log, time.monotonic())
        up, end = tool_node("held", proc.pid), time.monotonic() + HELD_UP_WITHIN
        while not ctx.hold_stop.is_set() and time.monotonic() < end and comp in ctx.held and \
                up not in (n for n, _ in ctx.rt.node.get_node_names_and_namespaces()):
            time.sleep(0.02)
        if ctx.hold_stop.is_set():
            return


def _release(ctx: Context, comp: str, argv: list[str], log: str) -> Optional[Held]:
    """The held process of `comp`, released, if there is one still held for this command: the
    same, or the same but for the names the create chose (`--as X --node N`), which it then
    takes; its log renamed to `log` (the node's name)."""
    holding = ctx.holding
    if holding is not None:           # until it has forked this one (or stopped)
        ctx.rt.wait(lambda: comp in ctx.held or not holding.is_alive(), ctx.rt.left())
    held = ctx.held.pop(comp, None)
    if held is None:
        return None
    names, rest = {}, argv
    if argv[1:2] == ["--as"] and argv[3:4] == ["--node"]:
        names, rest = {"as": argv[2], "node": argv[4]}, argv[:1] + argv[5:]
    try:
        if held.argv != rest or held.proc.poll() is not None:
            ctx.launcher.cancel(held.proc.pid)
            return None
        ctx.launcher.release(held.proc.pid, names)
    except OSError:
        return None                     # it exited while held, or the launcher is gone
    if held.log != log:
        try:
            os.replace(held.log, log)
            held.log = log
        except OSError:
            pass                        # it writes on where it was forked to write
    return held


def end_held(ctx: Context) -> None:
    """Cancel the processes still held at the end of a run (their creates were not reached, or
    adopted a node already there): each exits having made no node."""
    if ctx.holding is not None:
        ctx.hold_stop.set()
        ctx.holding.join(10.0)
        ctx.holding = None
    if ctx.held:
        ended = plural(len(ctx.held), "node process", "node processes")
        ctx.say(f"      {ended} forked ahead and never released: ended ({', '.join(sorted(ctx.held))})")
    for held in ctx.held.values():
        try:
            ctx.launcher.cancel(held.proc.pid)
        except OSError:
            pass                        # gone with the launcher: it exits all the same
    ctx.held.clear()


def wait_exit(proc: Any, seconds: float) -> int:
    """Wait for a process to exit: `seconds`, then SIGTERM and 2 s, then SIGKILL. Its status."""
    try:
        proc.wait(timeout=seconds)
    except subprocess.TimeoutExpired:
        proc.terminate()
        try:
            proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return int(proc.returncode)


def _stop(proc: Any) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=3)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=3)


def list_started(ctx: Context, stop: bool, present: Optional[Iterable[str]] = None) -> None:
    """Name every process this run started (pid, host, state, log); with `stop`, end the ones
    still running (SIGTERM, then SIGKILL after 3 s); and, whatever `stop`, those whose component
    is not in the `present` ones observed: never activated, they are in no configuration and
    would only stand in the way of a run or a recovery that starts them again. A process whose
    host's agent cannot be reached is named with that reason, its state unknown."""
    if not ctx.started:
        return
    keep = None if present is None else set(present)
    ctx.warn("Processes this run started:")
    for c, info in sorted(ctx.started.items()):
        where = f"pid {info.pid}{_on(info.host)}"
        try:
            alive = info.proc.poll() is None
            if alive and (stop or (keep is not None and c not in keep)):
                _stop(info.proc)
                info.ended = info.proc.returncode
                why = "--stop-started" if stop else "never active: in no configuration"
                ctx.warn(f"  {c}: {where} stopped ({why}), log {info.log}")
                continue
        except HostError as e:
            ctx.warn(f"  {c}: {where}, state not known ({e}), log {info.log}")
            continue
        state = "running" if alive else f"exited with status {info.proc.returncode}"
        ctx.warn(f"  {c}: {where} {state}, log {info.log}")


def _process(pid: Optional[int], mark: str) -> Optional[bool]:
    """Whether `pid` is a live process of this host whose environment carries the creation
    `mark` (True), another process or a zombie (False), or none (None)."""
    if not pid:
        return None
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            if fh.read().rsplit(")", 1)[1].split()[0] == "Z":
                return None
        with open(f"/proc/{pid}/environ", "rb") as fh:
            env = fh.read().split(b"\0")
    except (OSError, IndexError):
        return None
    return f"{CREATED_ENV}={mark}".encode() in env


def _wait_gone(pid: int, mark: str, seconds: float) -> bool:
    end = time.monotonic() + seconds
    while _process(pid, mark):
        if time.monotonic() >= end:
            return False
        time.sleep(0.05)
    return True


def end_orphan(ctx: Context, orphan: dict[str, Any]) -> str:
    """End a node a plan started that is in no configuration (docs/executor.md#recovering-from-the-live-system):
    down its lifecycle to finalized (a reconf node then exits), its process signalled if it does
    not exit (only a process of this host that carries the node's creation mark; on an agent's
    host, by that agent: `_end_remote`). What was done."""
    fqn, pid, mark = orphan["node"], orphan.get("pid"), orphan.get("created", "")
    transition = ctx.rt.Transition
    try:
        lc = ctx.rt.lifecycle(fqn) if fqn in ctx.rt.nodes() else "gone"
    except StepFailed:
        lc = "unresponsive"
    if lc == "active":
        raise StepFailed(f"the orphan {fqn} is active now: plan the recovery again")
    if lc in ("unconfigured", "inactive"):
        tid = transition.TRANSITION_UNCONFIGURED_SHUTDOWN if lc == "unconfigured" else \
            transition.TRANSITION_INACTIVE_SHUTDOWN
        try:
            ctx.rt.transition(fqn, tid, "shutdown")
        except StepFailed as e:
            lc = f"{lc}, shutdown refused ({e})"
    ctx.rt.forget(fqn)
    remote = _end_remote(ctx, fqn, str(orphan.get("component") or ""), int(pid)) if pid is not None else None
    if remote is not None:
        return f"{lc} → finalized, {remote}" if lc in ("unconfigured", "inactive") else f"{lc}, {remote}"
    if pid is None or _wait_gone(pid, mark, ctx.args.timeout):
        return f"{lc} → finalized, exited" if lc in ("unconfigured", "inactive") else f"{lc}"
    for sig in (signal.SIGTERM, signal.SIGKILL):
        if _process(pid, mark):
            os.kill(pid, sig)
            if _wait_gone(pid, mark, 3.0):
                return f"{lc}; did not exit, ended by {sig.name}"
    raise StepFailed(f"the orphan {fqn} (pid {pid}) did not exit")


def end_orphans(ctx: Context) -> str:
    """End every orphan a recovery's plan lists, before its first step; why one could not be
    ended ("": every one was)."""
    for orphan in ctx.orphans:
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        try:
            how = end_orphan(ctx, orphan)
        except StepFailed as e:
            return str(e)
        ctx.say(f"ended the orphan {orphan['node']} (pid {orphan.get('pid') or 'unknown'}): {how}")
    return ""


# --- reconf_ros/executor/handlers.py ---

def _adoptable(ctx: Context, comp: str, fqn: str) -> bool:
    """Whether the node `fqn` that runs already is `comp`'s and not active (a process an earlier
    run started and did not activate, or one deactivated): the create adopts it."""
    st = ctx.rt.status(fqn) or {}
    if st.get("component", ctx.names.declared(comp)) != ctx.names.declared(comp):
        return False
    try:
        return ctx.rt.lifecycle(fqn) in ("unconfigured", "inactive")
    except StepFailed:
        return False


def create(ctx: Context, step: Step) -> None:
    """Start the component's process (or adopt its node, there and not active), wait for its
    lifecycle services, configure and activate it; its monitor counts from then on."""
    comp, names = step.component, ctx.names
    if names.is_version(comp):        # X@new: a node name no other node has (X's may still run)
        names.locate([comp])
        if comp in names.placed and not _adoptable(ctx, comp, names.fqn(comp)):
            raise StepFailed(f"before the step, {comp} runs already (node {names.fqn(comp)})")
        names.placed.setdefault(comp, names.fresh(comp))
    fqn = names.fqn(comp)
    if fqn in ctx.rt.nodes() or ctx.rt.node.count_services(f"{fqn}/get_state"):
        if _adoptable(ctx, comp, fqn):
            _adopt(ctx, comp, fqn)
            return baseline(ctx, comp)
        if not _finalized(ctx, fqn):
            raise StepFailed(f"before the step, a node {fqn} is already running")
        names.placed[comp] = names.fresh(comp)     # the finalized node stays while its process runs others
        ctx.say(f"      {fqn} is a finalized node that stays in its process: {comp} starts as {names.fqn(comp)}")
        fqn = names.fqn(comp)
    _start(ctx, comp, fqn)
    baseline(ctx, comp)


def _finalized(ctx: Context, fqn: str) -> bool:
    """Whether the node `fqn` says it is finalized (its lifecycle, or its last status)."""
    if (ctx.rt.status(fqn) or {}).get("lifecycle") == "finalized":
        return True
    try:
        return ctx.rt.lifecycle(fqn) == "finalized"
    except StepFailed:
        return False


def _adopt(ctx: Context, comp: str, fqn: str) -> None:
    lc = ctx.rt.lifecycle(fqn)
    pid = (ctx.rt.status(fqn) or {}).get("pid", "unknown")
    if lc == "unconfigured":
        ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_CONFIGURE, "configure")
    ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_ACTIVATE, "activate")
    ctx.say(f"      adopted {comp}'s node {fqn} (pid {pid}, {lc}: started and left so by an earlier run): activated")


def baseline(ctx: Context, comp: str) -> None:
    """Take a new node's monitor's count of violations as it comes up: from then on it counts in
    every step's check and the final one (docs/executor.md)."""
    if wait_status(ctx, comp, lambda st: st.get("lifecycle") == "active", min(3.0, ctx.rt.left())):
        ctx.baseline[comp] = int((ctx.rt.status(ctx.names.fqn(comp)) or {}).get("violations", "0"))


def _start(ctx: Context, comp: str, fqn: str) -> None:
    """Start the component's process as `fqn` (here, or on its host by its agent: `launch`),
    wait for its lifecycle services, configure and activate it."""
    started = ctx.started[comp] = launch(ctx, comp)
    proc, cmd, log = started.proc, started.command, started.log
    ctx.ended.discard(comp)
    ctx.say(f"      started {comp}: pid {proc.pid}{started.how}, log {log}")
    ctx.rt.forget(fqn)
    t0 = time.monotonic()
    cli = ctx.rt.client(ctx.rt.GetState, f"{fqn}/get_state")
    plain: dict[str, float] = {}
    while not cli.service_is_ready():
        if proc.poll() is not None:
            raise StepFailed(f"{cmd} exited with status {proc.returncode} before {comp} came up "
                             f"(see {log})")
        _not_a_lifecycle_node(ctx, comp, fqn, plain)
        ctx.rt.wait(cli.service_is_ready, min(0.2, ctx.rt.left()))
    t_up = time.monotonic()
    if ctx.rt.nodes().count(fqn) > 1:
        raise StepFailed(f"two nodes named {fqn} are running")
    lc = ctx.rt.lifecycle(fqn)
    t_state = time.monotonic()
    if lc == "unconfigured":
        ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_CONFIGURE, "configure")
    elif lc != "inactive":
        raise StepFailed(f"after start, {comp} is in lifecycle state {lc!r}")
    ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_ACTIVATE, "activate")
    ctx.say(f"      {comp}'s services seen after {t_up - t0:.2f} s (process start and discovery), first answer "
            f"{t_state - t_up:.2f} s later, configured and activated in {time.monotonic() - t_state:.2f} s")


NOT_LIFECYCLE_AFTER = 1.5   # s a new node may serve parameters without lifecycle services before it is called plain


def _not_a_lifecycle_node(ctx: Context, comp: str, fqn: str, seen: dict[str, float]) -> None:
    """Fail at once, not at the step's timeout, when the process's node runs and serves its
    parameters but has had no lifecycle services for NOT_LIFECYCLE_AFTER s: not a reconf node."""
    node = ctx.rt.node
    if fqn in ctx.rt.nodes() and node.count_services(f"{fqn}/get_parameters") and \
            not node.count_services(f"{fqn}/get_state"):
        if time.monotonic() - seen.setdefault("since", time.monotonic()) > NOT_LIFECYCLE_AFTER:
            raise StepFailed(f"{comp}'s process runs node {fqn}, which serves no lifecycle services: not a reconf "
                             f"node; {NOT_A_RECONF_NODE}")
    else:
        seen.pop("since", None)


def remove(ctx: Context, step: Step) -> None:
    """Take an isolated node down its lifecycle to finalized; wait for a process this run started,
    and, for a component on an agent's host, for the agent's report of its process's exit
    (`wait_removed`: an agent that cannot be reached fails the step, naming the host)."""
    comp = step.component
    fqn, transition = ctx.names.fqn(comp), ctx.rt.Transition
    lc = ctx.rt.lifecycle(fqn)
    if lc not in ("active", "inactive"):
        raise StepFailed(f"before the step, {comp} is in lifecycle state {lc!r}")
    ports = [p["name"] for p in ctx.model.comps[comp]["ports"]]
    attached = {n: v for n, v in ctx.rt.get(fqn, [f"reconf.port.{p}" for p in ports]).items() if v}
    if attached:
        raise StepFailed(f"before the step, {comp} is not isolated: "
                         + ", ".join(f"{n}={v!r}" for n, v in sorted(attached.items())))
    pid = (ctx.rt.status(fqn) or {}).get("pid") if on_agent(ctx, comp) else None
    if lc == "active":
        ctx.rt.transition(fqn, transition.TRANSITION_DEACTIVATE, "deactivate")
    ctx.rt.transition(fqn, transition.TRANSITION_CLEANUP, "cleanup")
    ctx.rt.transition(fqn, transition.TRANSITION_UNCONFIGURED_SHUTDOWN, "shutdown")
    # finalized: the node may exit at once, which counts as removed
    try:
        lc = ctx.rt.lifecycle(fqn)
    except StepFailed:
        lc = "finalized"
    if lc != "finalized":
        raise StepFailed(f"after shutdown, {comp} is in lifecycle state {lc!r}")
    # its process may exit at any moment, and its node linger in the graph not answering: a
    # reading after this step must not ask it (it would wait for the call's timeout)
    ctx.ended.add(comp)
    seen = wait_removed(ctx, comp, int(str(pid)) if str(pid or "").isdigit() else None,
                        max(0.1, min(ctx.args.timeout, ctx.rt.deadline - time.monotonic())))
    if seen:
        ctx.say(f"      {comp}: {seen}")
    ctx.rt.forget(fqn)


def _port(ctx: Context, step: Step, attach: bool) -> None:
    """Set `reconf.port.<p>` to its current list with the connector added (or taken away)."""
    comp, port, conn = step.component, step.port, ctx.names.connector(step.connector)
    fqn, name = ctx.names.fqn(comp), f"reconf.port.{port}"
    _expect_active(ctx, comp)
    now = ctx.rt.get(fqn, [name])[name]
    if (conn in now) == attach:
        raise StepFailed(f"before the step, {comp}.{port} is {'already' if attach else 'not'} attached to "
                         f"{conn} ({name}={now!r})")
    ctx.rt.set(fqn, name, sorted(set(now) | {conn}) if attach else [c for c in now if c != conn])


def _mode(ctx: Context, step: Step, was: str, will: str) -> None:
    """Set `reconf.mode.<f>` from `was` to `will`."""
    comp, func = step.component, step.functionality
    fqn, name = ctx.names.fqn(comp), f"reconf.mode.{func}"
    _expect_active(ctx, comp)
    now = ctx.rt.get(fqn, [name])[name]
    if now != was:
        raise StepFailed(f"before the step, {comp}.{func} is {now!r}, not {was!r}")
    ctx.rt.set(fqn, name, will)


def _expect_active(ctx: Context, comp: str) -> None:
    lc = ctx.rt.lifecycle(ctx.names.fqn(comp))
    if lc != "active":
        raise StepFailed(f"before the step, {comp} is in lifecycle state {lc!r}")


HANDLERS: dict[str, Callable[[Context, Step], None]] = {
    "create": create,
    "remove": remove,
    "attach": lambda ctx, step: _port(ctx, step, attach=True),
    "detach": lambda ctx, step: _port(ctx, step, attach=False),
    "degrade": lambda ctx, step: _mode(ctx, step, "normal", "degraded"),
    "upgrade": lambda ctx, step: _mode(ctx, step, "degraded", "normal"),
}


def perform(ctx: Context, step: Step, was: State, will: State) -> None:
    """One step: its wire condition before, its handler, its wire condition after."""
    ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
    ctx.began = time.time()
    wire_before(ctx, step, was, will)
    HANDLERS[step.action](ctx, step)
    wire_after(ctx, step, will)


# --- reconf_ros/executor/run_report.py ---

def write_report(ctx: Context, outcome: str, first: int, observed: Optional[State],
                 failed_step: Optional[int] = None, why: Optional[str] = None) -> str:
    """Write the run's report (JSON, atomically); return its path ("" when none is asked for)."""
    path = ctx.args.report or (f"reconf-{ctx.doc['system']}-{outcome}.json" if outcome != "done" else "")
    if not path:
        return ""
    body: dict[str, Any] = {
        "format_version": 1, "tool": "reconf", "kind": "run-report", "outcome": outcome,
        "system": ctx.doc["system"], "fingerprint": ctx.doc["fingerprint"], "from_step": first,
        "failed_step": failed_step, "reason": why,
        "failed_host": ctx.failed_host or None,     # the host whose agent failed the step (docs/hosts.md)
        "observed": None if observed is None else observed.to_doc(),
        "observed_at": None if observed is None else ctx.read_at,    # when that reading began (wall clock)
        "unread": sorted(ctx.unread),     # components whose node did not answer: not in `observed`, not known
        "observed_valid": None if observed is None else not ctx.model.failures(observed),
        "timings": [t.to_doc() for t in ctx.timings],
        # each monitor that saw a normal mode's assumption violated: how often, first after which
        # step, and its last violation as its status said it (when it began, on the wall clock; why)
        "violated": {c: {"violations": ctx.violations.get(c, 0), "after_step": i,
                         "last": ctx.last_violation.get(c)} for c, i in sorted(ctx.violated.items())},
        "gaps": gaps(ctx),
        "started": {c: info.to_doc() for c, info in ctx.started.items()},
        "placed": {c: n for c, n in ctx.names.placed.items() if "@" not in n} if ctx.rt is not None else {},
        "plan_document": ctx.doc}
    if ctx.interrupts.stop:
        body["interrupted_by"] = ctx.interrupts.by
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(body, fh, indent=1, sort_keys=True)
    os.replace(tmp, path)
    print(f"report: {path}", file=ctx.err if outcome != "done" else ctx.out)
    return path


def gaps(ctx: Context) -> dict[str, dict[str, Any]]:
    """Each monitored input's largest wait for data as its node's last status says, and whether
    the run saw it (larger than before the first step, or on a node the run started): "comp.port"
    -> {"seconds", "during_run"}. Its node's status comes once a second: a gap of the last
    second before the report may not be in it yet."""
    if ctx.rt is None:
        return {}
    now = largest_gaps(ctx, ctx.baseline)
    return {k: {"seconds": round(s, 3), "during_run": s > ctx.gaps.get(k, 0.0)} for k, s in sorted(now.items())}


def stale(ctx: Context, first: int, observed: State, diffs: list[str], hood: set[str]) -> int:
    """Refuse a plan whose state before step `first` is not what the live system shows; say
    which state of the plan it is, if any."""
    ctx.warn(f"refusing to apply: the live system does not match the plan's state before step {first}:")
    for d in diffs:
        ctx.warn(f"  - {d}")
    matches = [i for i, s in enumerate(ctx.states) if not ctx.model.differences(s, observed, hood)]
    if matches:
        i = matches[-1]
        ctx.warn(f"It matches the state after step {i}" + (" (the plan's last: it was applied already)"
                                                          if i == len(ctx.steps) else "")
                 + (f"; resume with --from-step {i + 1}" if i < len(ctx.steps) else "") + ".")
    else:
        ctx.warn("Plan again from the running system (the plan is stale).")
    write_report(ctx, "stale", first, observed=observed)
    return EXIT_FAILED


def _judge(ctx: Context, i: int, observed: State, seen: dict[str, Observed]) -> None:
    """Print the observed configuration, whether it is valid, and which plan state it is."""
    ctx.warn("Observed configuration (read from the running nodes):\n    " + observed.describe())
    unusual(ctx, seen)
    bad = ctx.model.failures(observed)
    if bad:
        ctx.warn("It is NOT valid:")
        for b in bad:
            ctx.warn(f"  - {b}")
    else:
        ctx.warn("It is valid: every assumption of every present functionality holds in the model.")
    if i == 0 and not ctx.model.differences(ctx.states[0], observed, ctx.model.comps):
        ctx.warn("It is the plan's first state: nothing was done.")
    for k, name in ((i - 1, "before"), (i, "after")) if i else ():
        if not ctx.model.differences(ctx.states[k], observed, ctx.model.comps):
            ctx.warn(f"It is the plan's state {name} step {i}.")


def _observe_all(ctx: Context) -> tuple[Optional[State], dict[str, Observed]]:
    try:
        return read_all(ctx)
    except StepFailed as e:
        ctx.warn(f"could not observe the system after the failure: {e}")
        return None, {}


def failed(ctx: Context, i: int, step: Optional[Step], why: str) -> int:
    """Step `i` failed: read every component, say what the system is now and how to recover."""
    ctx.warn(f"step {i} ({step.describe()}) FAILED: {why}" if step is not None else f"FAILED: {why}")
    observed = _report_observed(ctx, i)
    path = write_report(ctx, "failed", i, observed=observed, failed_step=i, why=why)
    _how_to_recover(ctx, path)
    return EXIT_FAILED


def interrupted(ctx: Context, i: int, at_once: bool = False) -> int:
    """The run was interrupted (docs/executor.md#interrupted): after step `i` (0: before the
    first), or, `at_once`, during it. Read every component, say what the system is now, name
    the processes the run started, write the report. Another signal meanwhile leaves the
    configuration unread, and says so."""
    by = ctx.interrupts.by or "a signal"
    if i < 0:                           # during the final check: every step was done
        i, where = ctx.args.to_step, "during the final check"
        at_once = False
    else:
        where = (f"during step {i} ({ctx.steps[i - 1].describe()})" if at_once and i else
                 f"after step {i}" if i else "before the first step")
    ctx.warn(f"INTERRUPTED by {by} {where}" + (": stopped at once" if at_once else
                                                ": stopped at the step's end" if i and "check" not in where else ""))
    if at_once and i:
        ctx.timings = [t for t in ctx.timings if t.step != i] + [StepTiming(i, time.time(), 0.0, False)]
    observed: Optional[State] = None
    try:
        observed = _report_observed(ctx, i)
    except KeyboardInterrupt:
        ctx.warn("interrupted again: the configuration was not read")
        list_started(ctx, False)
    path = write_report(ctx, "interrupted", i, observed=observed, failed_step=i if at_once and i else None,
                        why=f"interrupted by {by} {where}")
    if observed is not None:
        _how_to_recover(ctx, path)
    return EXIT_INTERRUPTED


def _report_observed(ctx: Context, i: int) -> Optional[State]:
    """Every component read and judged; the processes started named (those never activated
    ended: they are in no configuration); the configuration observed."""
    ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
    observed, seen = _observe_all(ctx)
    if observed is not None:
        _judge(ctx, i, observed, seen)
    list_started(ctx, ctx.args.stop_started, None if observed is None else observed.components)
    if ctx.started and ctx.args.stop_started and observed is not None:
        observed = _observe_all(ctx)[0]
    return observed


def _how_to_recover(ctx: Context, path: str) -> None:
    ctx.warn(f"To recover, plan from the observed configuration:\n"
             f"    reconf recover {path} --yes           (on to the plan's target)\n"
             f"    reconf recover {path} --back --yes    (back to the plan's start)\n"
             f"    (-o recover.py writes the plan as a script instead)")


def degraded_line(ctx: Context, first: int) -> str:
    """A whole plan's run: each functionality that served before it and was degraded, for how long
    by the steps' times, next to the plan's estimate, the longest three first, and in all (""
    for a run of part of a plan, or a plan without an estimate)."""
    estimate = ctx.doc["plan"].get("seconds") or {}
    if not estimate or first != 1 or ctx.args.to_step != len(ctx.steps):
        return ""
    planned = {f"{f['component']}.{f['functionality']}": float(f["seconds"]) for f in estimate.get("functionalities", [])}
    timed = [(t.step, t.at, t.at + t.seconds, t.ok) for t in ctx.timings]
    removes = {t.step for t in ctx.timings if ctx.steps[t.step - 1].action == "remove"}
    served = ctx.states[0].components
    spans = degraded_spans(ctx.states, timed, removes, max((t[2] for t in timed), default=0.0))
    measured = {n: sum(b - a for a, b in s) for n, s in spans.items() if n.split(".", 1)[0] in served}
    measured = {n: s for n, s in measured.items() if s > 0}
    if not measured and not planned:
        return "degraded on the wire: no functionality that served before the run (the plan expected none)"
    names = sorted(set(measured) | set(planned), key=lambda n: (-measured.get(n, 0.0), n))
    shown = ", ".join(f"{n} {measured.get(n, 0.0):.2f} s (plan ~{planned.get(n, 0.0):.2f} s)" for n in names[:3])
    return (f"degraded on the wire, by the steps' times: {shown}{', …' if len(names) > 3 else ''}; "
            f"{sum(measured.values()):.2f} s in all (plan ~{sum(planned.values()):.2f} s)")


# --- reconf_ros/executor/run.py ---

def busy(timings: list[StepTiming]) -> float:
    """The seconds in which some step ran: the steps of a batch overlap, and count once."""
    total, reach = 0.0, float("-inf")
    for start, end in sorted((t.at, t.at + t.seconds) for t in timings):
        total += max(0.0, end - max(start, reach))
        reach = max(reach, end)
    return total


def confirmed(doc: dict[str, Any], args: argparse.Namespace, out: Writer) -> bool:
    """List the steps to apply; unless --yes, ask."""
    first, last = args.from_step, args.to_step
    if args.quiet_list and args.yes:      # a manager: its client has listed them
        return True
    print(f"applying steps {first}..{last} of the plan for {doc['system']} ({doc['fingerprint']})", file=out)
    for i, step in enumerate(plan_steps(doc)[first - 1:last], first):
        print(step.label(i), file=out)
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


class Executor:
    """Applies a plan document's steps to the running system (docs/executor.md). A manager lends
    its long-lived `runtime`, its `launcher` and its `interrupts`; a plan script makes its own
    runtime and takes SIGINT and SIGTERM itself once the steps are confirmed."""

    def __init__(self, doc: dict[str, Any], args: argparse.Namespace, out: Writer = sys.stdout,
                 err: Writer = sys.stderr, runtime: Any = None, launcher: Any = None,
                 interrupts: Optional[Interrupts] = None) -> None:
        self.ctx = Context(doc, args, out, err, rt=runtime, launcher=launcher)
        self.own_runtime = runtime is None
        self.settled_at = 0.0           # when discovery had settled before the first step (monotonic)
        if interrupts is not None:
            self.ctx.interrupts = interrupts

    def apply(self, first: int) -> int:
        ctx = self.ctx
        if not confirmed(ctx.doc, ctx.args, ctx.out):
            return EXIT_FAILED
        t0 = time.monotonic()
        if self.own_runtime:
            ctx.interrupts.install()
            own_launcher(ctx, first, ctx.args.to_step)    # before rclpy: its imports overlap discovery
            ctx.rt = Runtime(ctx.doc["system"], ctx.args.namespace, ctx.args.timeout)
        try:
            return self._apply(first, t0)
        except KeyboardInterrupt:       # a second signal: at once, wherever the run was
            return interrupted(ctx, ctx.step, at_once=True)
        except (StepFailed, OSError) as e:   # outside a step: the start check, the final check
            return self._failed_outside(e)
        finally:
            end_held(ctx)
            if ctx.hosts is not None:
                ctx.hosts.close()
            if self.own_runtime and ctx.launcher is not None:
                ctx.launcher.close(wait=False)  # its children, the nodes started, stay
            if self.own_runtime:
                ctx.rt.close(exiting=True)

    def _apply(self, first: int, t0: float) -> int:
        ctx, last = self.ctx, self.ctx.args.to_step
        forks = forkable(ctx, first, last)
        warm(ctx, forks)
        hold(ctx, forks)
        hood = neighbourhood(ctx)
        refused = self._check_start(first, hood)
        if refused is not None:
            return refused
        if ctx.interrupts.stop:
            return interrupted(ctx, 0)
        why = end_orphans(ctx)
        if why:
            return failed(ctx, 0, None, f"before the first step: {why}")
        wait_statuses(ctx, hood & ctx.states[first - 1].components)
        # every monitor heard from, not only the neighbourhood's: a step can reach further on the
        # wire than in the model (a suspended protocol keeps its clients waiting); a node a step
        # creates joins them as it comes up (handlers.baseline)
        ctx.baseline = violations(ctx, ctx.states[first - 1].components)
        ctx.gaps = largest_gaps(ctx, ctx.states[first - 1].components)
        ctx.touched = {s.component for s in ctx.steps[first - 1:last]} & hood
        check_at = time.monotonic()
        ctx.say(f"the live system matches the plan's state before step {first} "
                f"({plural(len(hood), 'component')} checked in {check_at - t0:.2f} s: waiting for discovery "
                f"{self.settled_at - t0:.2f} s, the graph's last change {ctx.rt.graph_since - ctx.rt.started_at:.2f} s "
                f"after it began, reading {check_at - self.settled_at:.2f} s)")
        i = first
        while i <= last:
            end = batch_end(ctx, i, last)
            if not (self._step(i) if end == i else self._batch(i, end)):
                return failed(ctx, ctx.step, ctx.steps[ctx.step - 1], ctx.failure)
            i = end + 1
            if ctx.args.pause > 0 and i <= last and not ctx.interrupts.stop:
                ctx.rt.deadline = time.monotonic() + ctx.args.pause + 1.0
                ctx.rt.wait(lambda: ctx.interrupts.stop, ctx.args.pause)
            if ctx.interrupts.stop and i <= last:
                return interrupted(ctx, i - 1)
        return self._finish(first, hood, t0, check_at)

    def _failed_outside(self, e: Exception) -> int:
        """A reading before the first step or in the final check failed (a node that answered
        one call and not the next, the step's time up): a failure like a step's, reported."""
        ctx = self.ctx
        if ctx.step < 0:
            last = ctx.args.to_step
            return failed(ctx, last, ctx.steps[last - 1] if last else None, f"during the final check: {e}")
        if ctx.step == 0:
            return failed(ctx, 0, None, f"before the first step: {e}")
        return failed(ctx, ctx.step, ctx.steps[ctx.step - 1], str(e))

    def _check_start(self, first: int, hood: set[str]) -> Optional[int]:
        """Refuse (the exit status) unless the live system is the plan's state before `first`."""
        ctx = self.ctx
        start = ctx.states[first - 1]
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        settle(ctx, start.components & hood, ctx.args.discovery_timeout)
        self.settled_at = time.monotonic()
        seen = observe(ctx, hood)
        busy = sorted(c for c, o in seen.items() if o.lifecycle == "unresponsive")
        if busy:    # a node of a saturated host can take longer than one call's timeout to answer
            ctx.say(f"not answering within {ctx.args.timeout} s: {', '.join(busy)}; reading them again")
            seen.update(observe(ctx, busy))
        observed = as_state(ctx, seen)
        diffs = ctx.model.differences(start, observed, hood)
        if not diffs:
            return None
        unusual(ctx, seen)
        return stale(ctx, first, observed, diffs, hood)

    def _step(self, i: int) -> bool:
        """Perform step `i` and read back what the plan has touched; False (the reason in
        `ctx.failure`) when it failed or was interrupted."""
        ctx = self.ctx
        step = ctx.steps[i - 1]
        ctx.say(f"{step.label(i)} ...")
        s0, at = time.monotonic(), round(time.time(), 3)
        ctx.step = i
        try:
            perform(ctx, step, ctx.states[i - 1], ctx.states[i])
            ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
            check_touched(ctx, ctx.states[i], f"after step {i}")
        except (StepFailed, OSError) as e:     # OSError: a host's agent (HostError, naming the host), a file
            ctx.failure = str(e)
            ctx.failed_host = e.host if isinstance(e, HostError) else ""
            ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, False))
            return False
        except KeyboardInterrupt:
            ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, False))
            raise
        ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, True, step.action))
        ctx.say(f"      done in {time.monotonic() - s0:.3f} s")
        counted(ctx, i)
        return True

    def _batch(self, first: int, last: int) -> bool:
        """Perform steps `first`..`last` together (docs/executor.md#batches), each in a thread
        of its own with its wire conditions, then read back what the plan has touched; on the
        first failure the others stop at their next wait, and the batch fails with it."""
        ctx = self.ctx
        ctx.say(f"steps {first}–{last} together:")
        for i in range(first, last + 1):
            ctx.say(ctx.steps[i - 1].label(i))
        ctx.step, was = first, ctx.states[first - 1]
        failures: dict[int, str] = {}
        workers = [threading.Thread(target=self._together, args=(i, was, failures), daemon=True)
                   for i in range(first, last + 1)]
        s0 = time.monotonic()
        try:
            for w in workers:
                w.start()
            for w in workers:
                while w.is_alive():     # in steps, so that a signal is taken at once
                    w.join(0.05)
        except KeyboardInterrupt:       # a second signal: the others stop at their next wait
            ctx.rt.halt.set()
            for w in workers:
                w.join(ctx.args.timeout)
            raise
        finally:
            ctx.rt.halt.clear()
            ctx.timings.sort(key=lambda t: t.step)
        if failures:
            ctx.step = min(failures, key=lambda i: (failures[i].startswith("stopped: "), i))
            ctx.failure = failures[ctx.step]
            return False
        ctx.step = last
        try:
            ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
            check_touched(ctx, ctx.states[last], f"after steps {first}–{last}")
        except (StepFailed, OSError) as e:
            ctx.failure, ctx.failed_host = str(e), e.host if isinstance(e, HostError) else ""
            return False
        ctx.say(f"      steps {first}–{last} done in {time.monotonic() - s0:.3f} s")
        counted(ctx, last)
        return True

    def _together(self, i: int, was: State, failures: dict[int, str]) -> None:
        """Step `i` of a batch that began in state `was`: its wire conditions are judged against
        `was` with this step alone done (its steps commute: docs/soundness.md#batches)."""
        ctx, step = self.ctx, self.ctx.steps[i - 1]
        s0, at = time.monotonic(), round(time.time(), 3)
        try:
            perform(ctx, step, was, ctx.states.alone(was, i))
        except (StepFailed, OSError) as e:
            failures[i] = str(e)
            if isinstance(e, HostError):
                ctx.failed_host = e.host
            ctx.rt.halt.set()
            ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, False))
            return
        ctx.timings.append(StepTiming(i, at, time.monotonic() - s0, True, step.action))
        ctx.say(f"      step {i} done in {time.monotonic() - s0:.3f} s")

    def _finish(self, first: int, hood: set[str], t0: float, check_at: float) -> int:
        """After the last step: the neighbourhood reads back as the plan's last state, the
        touched functionalities meet their assumptions on the wire, and no monitor's count moved
        (every monitor heard from at the start, and every node the plan created)."""
        ctx, last = self.ctx, self.ctx.args.to_step
        ctx.step = -1                   # the final check
        final_at = time.monotonic()
        end = ctx.states[last]
        normal = [(c, f["name"]) for c in sorted(ctx.touched & end.components)
                  for f in ctx.model.comps[c]["functionalities"] if (c, f["name"]) not in end.degraded]
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        unmet = [f"{c}.{f}" for c, f in normal if not wait_status(ctx, c, meets(f), ctx.args.wire_timeout)]
        # every component, not only the neighbourhood: the report says the whole configuration
        final, _ = read_all(ctx)
        wrong = ctx.model.differences(end, final, hood)
        if wrong:
            return failed(ctx, last, ctx.steps[last - 1] if last else None, "after the last step: " + "; ".join(wrong))
        seen_bad = counted(ctx, last)
        upto = "" if last == len(ctx.steps) else f"; stopped after step {last} as asked (--to-step)"
        done = last - first + 1
        now, steps = time.monotonic(), busy(ctx.timings)
        ctx.say(("no step" if done <= 0 else f"all {done} steps" if done != 1 else "the 1 step")
                + f" done in {now - t0:.2f} s (checking the live system {check_at - t0:.2f} s, steps "
                f"{steps:.2f} s, between steps {max(0.0, final_at - check_at - steps):.2f} s, "
                f"the final check {now - final_at:.2f} s){upto}")
        line = degraded_line(ctx, first)
        if line:
            ctx.say(line)
        if unmet or seen_bad:
            if unmet:
                ctx.warn(f"but on the wire, the assumptions of {', '.join(unmet)} are not met")
            for c, n in sorted(seen_bad.items()):
                last = ctx.last_violation.get(c)
                ctx.warn(f"but the monitor of {c} saw {plural(n, 'violation')} of a normal mode's assumption "
                         f"during the run (first seen after step {ctx.violated[c]})"
                         + (f"; the last began {in_run(ctx, last)}" if last else ""))
            write_report(ctx, "violated", first, observed=final)
            return EXIT_FAILED
        heard = len(ctx.baseline)
        ctx.say("on the wire: every functionality the plan touched meets its assumptions, and "
                + (f"none of the {heard} monitors heard from saw" if heard != 1 else
                   "the 1 monitor heard from did not see")
                + " a normal mode's assumption violated during the run")
        write_report(ctx, "done", first, observed=final)
        return EXIT_OK


def counted(ctx: Context, i: int) -> dict[str, int]:
    """Each counted monitor's violations since its baseline (those whose count moved), the step
    after which each was first seen noted in `ctx.violated`."""
    now = violations(ctx, ctx.baseline)
    moved = {c: now[c] - n for c, n in ctx.baseline.items() if now.get(c, n) > n}
    for c in moved:
        ctx.violated.setdefault(c, i)
    ctx.violations.update(moved)
    ctx.last_violation.update(last_violations(ctx, moved))
    return moved


def in_run(ctx: Context, last: str) -> str:
    """A monitor's `last_violation` ("<wall clock> <functionality>: why") with its time placed
    among the steps' (the nodes and this executor read one clock, or clocks kept in step)."""
    at, _, what = last.partition(" ")
    try:
        t = float(at)
    except ValueError:
        return last
    past = [s for s in ctx.timings if s.at <= t]
    if not past:
        return f"before step {ctx.timings[0].step if ctx.timings else 1}: {what}"
    s = past[-1]
    if t <= s.at + s.seconds:
        return f"{t - s.at:.2f} s into step {s.step}: {what}"
    return f"{t - s.at - s.seconds:.2f} s after step {s.step}: {what}"


# --- reconf_ros/executor/script.py ---

def manager_socket(namespace: str = "") -> str:
    """Where the manager of this ROS domain (and namespace) listens by default."""
    base = os.environ.get("XDG_RUNTIME_DIR") or os.path.join("/tmp", f"reconf-{os.getuid()}")
    ns = namespace.strip("/").replace("/", "_")
    return os.path.join(base, "reconf", f"manager-{os.environ.get('ROS_DOMAIN_ID', '0')}{'-' + ns if ns else ''}.sock")


def via_manager(doc: dict[str, Any], argv: list[str], args: argparse.Namespace, path: str) -> int:
    """Have a running manager (`python -m reconf_ros.tools.manager`) apply the plan: it has discovered
    the system already, so no discovery wait here (docs/executor.md#manager). Output streams back."""
    import socket
    if not confirmed(doc, args, sys.stdout):
        return EXIT_FAILED
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(path)
    except OSError as e:
        print(f"no reconf manager at {path} ({e.strerror or e}): start one with `python -m reconf_ros.tools.manager`, "
              "or leave out --manager to apply the plan from this process", file=sys.stderr)
        return EXIT_USAGE
    request = {"doc": doc, "argv": argv + ["--yes", "--quiet-list", "--cwd", os.getcwd()]}

    def forward(signum: int, frame: Any) -> None:
        """A signal to this script asks the manager to stop the run (docs/executor.md#interrupted)."""
        try:
            sock.sendall(json.dumps({"stop": signal.Signals(signum).name}).encode() + b"\n")
        except OSError:
            pass
    with sock, sock.makefile("rwb") as stream:
        stream.write(json.dumps(request).encode() + b"\n")
        stream.flush()
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, forward)
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
    ap.add_argument("--pause", type=float, default=0.0, metavar="S",
                    help="wait S seconds after each step but the last, to watch it on the wire (a signal "
                         "stops the run there)")
    ap.add_argument("--one-at-a-time", action="store_true",
                    help="perform every step alone, the steps of the plan's batches too (docs/executor.md#batches)")
    ap.add_argument("--no-launcher", action="store_true",
                    help="start each new node as a Python of its own, not forked from a launcher this script "
                         "starts (docs/executor.md#launcher)")
    ap.add_argument("--no-hold", action="store_true",
                    help="fork each new node at its create step, not ahead, held while the live system is "
                         "checked and the steps before run (docs/executor.md#held)")
    ap.add_argument("--namespace", default="", help="namespace of the components' nodes")
    ap.add_argument("--log-dir", default="", metavar="DIR",
                    help="where started processes write their output (default ./reconf-logs/SYSTEM-TIME-PID)")
    ap.add_argument("--report", default="", metavar="FILE",
                    help="write the run's report (JSON) here; on failure one is always written")
    ap.add_argument("--stop-started", action="store_true",
                    help="on failure, stop the processes this run started (they are named either way)")
    ap.add_argument("--hosts", default="", metavar="FILE",
                    help="a hosts file: each component whose host it names (not \"local\") is started and stopped "
                         "by that host's agent (docs/hosts.md)")
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
    if steps and not args.from_step <= args.to_step <= len(steps):
        ap.error(f"--to-step must be between --from-step and {len(steps)}")
    if not steps and args.to_step:
        ap.error("--to-step: the plan has no step")
    if min(args.timeout, args.step_timeout, args.wire_timeout, args.discovery_timeout) <= 0:
        ap.error("timeouts must be positive")
    if args.hosts:
        try:
            read_hosts(args.hosts)
        except OSError as e:
            ap.error(f"--hosts: {e.filename or args.hosts}: {e.strerror or e}")
        except ValueError as e:
            ap.error(f"--hosts: {e}")
    return args


def main(doc: dict[str, Any], argv: Optional[list[str]] = None) -> int:
    """The script: replay the plan, then apply it here or through a manager. SIGINT and SIGTERM
    end it quietly (exit 130) until the run takes them over (docs/executor.md#interrupted)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        return _main(doc, argv)
    except KeyboardInterrupt:
        print("interrupted before any step: nothing done", file=sys.stderr)
        return EXIT_INTERRUPTED


def _main(doc: dict[str, Any], argv: Optional[list[str]]) -> int:
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
    if not steps and not orphans(doc):
        print("nothing to do: the plan has no step")
        return EXIT_OK
    if args.manager:
        forwarded = [f"--{k.replace('_', '-')}={getattr(args, k)}" for k in (
            "from_step", "to_step", "timeout", "step_timeout", "wire_timeout", "discovery_timeout", "namespace",
            "pause")]
        forwarded += [f"--{k.replace('_', '-')}={os.path.abspath(getattr(args, k))}" for k in ("log_dir", "report", "hosts")
                      if getattr(args, k)]      # the manager writes them: absolute paths
        forwarded += ["--stop-started"] if args.stop_started else []
        return via_manager(doc, forwarded, args,
                           manager_socket(args.namespace) if args.manager == "default" else args.manager)
    import importlib.util
    if importlib.util.find_spec("rclpy") is None:
        print("ROS 2 is not available (no module rclpy): install reconf with its `ros` extra "
              "(pip install 'reconf[ros]'), or source a ROS 2 installation; --dry-run needs neither.", file=sys.stderr)
        return EXIT_USAGE
    return Executor(doc, args).apply(args.from_step)

for _sig in (signal.SIGINT, signal.SIGTERM):    # until main() takes them: quietly, nothing done
    signal.signal(_sig, lambda signum, frame: sys.exit(130))

DOC = json.loads(r"""{
 "command": "plan",
 "degradation": {
  "functionalities": {
   "listener.listen": 6,
   "talker_v2.talk": 1
  },
  "longest": 6,
  "longest_functionality": "listener.listen"
 },
 "evidence": {
  "python_engine": "all 8 states valid"
 },
 "fingerprint": "sha256:17c989dbb5df61a6894b234c81e1123137d50bb228850ec81b63050cbff9e9c5",
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
   {"add": {"degraded": [["listener", "listen"]]}},
   {"drop": {"roles": [["/chatter", "talker", "out"]]}},
   {"drop": {"components": ["talker"]}},
   {"add": {"components": ["talker_v2"], "degraded": [["talker_v2", "talk"]]}},
   {"drop": {"degraded": [["talker_v2", "talk"]]}},
   {"add": {"roles": [["/chatter", "talker_v2", "out"]]}},
   {"drop": {"degraded": [["listener", "listen"]]}}
  ],
  "disruption": 7,
  "left_degraded": [],
  "notes": [],
  "renames": {},
  "seconds": {
   "durations": {"components": [], "kinds": {"attach": 0.06, "create": 0.11, "degrade": 0.01, "detach": 0.01, "remove": 0.03, "upgrade": 0.03}, "sources": ["measured defaults"]},
   "functionalities": [{"component": "listener", "functionality": "listen", "seconds": 0.27}],
   "plan": 0.28,
   "weighted": 0.27
  },
  "start": {
   "components": ["listener", "talker"],
   "degraded": [],
   "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"]]
  },
  "steps": [
   {"action": "degrade", "component": "listener", "functionality": "listen"},
   {"action": "detach", "component": "talker", "connector": "/chatter", "port": "out"},
   {"action": "remove", "component": "talker"},
   {"action": "create", "component": "talker_v2"},
   {"action": "upgrade", "component": "talker_v2", "functionality": "talk"},
   {"action": "attach", "component": "talker_v2", "connector": "/chatter", "port": "out"},
   {"action": "upgrade", "component": "listener", "functionality": "listen"}
  ],
  "strategy": "paper",
  "verification": "full"
 },
 "system": "chatter",
 "tool": "reconf",
 "verdict": "plan"
}""")

if __name__ == "__main__":
    sys.exit(main(DOC))
