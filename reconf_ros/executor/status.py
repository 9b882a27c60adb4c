"""The status protocol: what every reconf node publishes on `/diagnostics` (its keys are listed in
docs/control-interface.md#status-on-diagnostics; `reconf_ros.nodes.component` writes it), and how a
component's node is found by its name or by what its status declares (docs/executor.md#names)."""
from __future__ import annotations

import os
from typing import Any, Iterable, Optional

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
