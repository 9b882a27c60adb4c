"""Drift: the model's deployed configuration against a snapshot of the running system
(`reconf_ros.graph.Snapshot`), each difference a diagnostic at the model's span. Pure Python:
no ROS here (docs/runtime.md#drift).

The deployed configuration is `Configuration.initial`: every component present and active,
every functionality normal, every declared attachment in place and no other.
"""
from __future__ import annotations

from typing import Callable, Optional

from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import Component, System
from reconf_dsl.span import Span
from reconf_ros.graph import NodeInfo, Snapshot

from .config import Configuration

__all__ = ["drift", "locate", "KINDS"]

KINDS = {"RC611": "component missing", "RC612": "component extra", "RC613": "attachment",
         "RC614": "message type", "RC615": "mode", "RC616": "publishers on a single connector",
         "RC617": "lifecycle"}


def _d(code: str, message: str, span: Span, *notes: str) -> Diagnostic:
    return Diagnostic(code, Severity.ERROR, message, span, notes=tuple(notes))


def locate(system: System, snap: Snapshot) -> dict[str, NodeInfo]:
    """Each deployed component's node: the node named after it, unless that node declares another
    component, else the one node that declares it (a new version's node, `X_2`; docs/executor.md#names)."""
    found: dict[str, NodeInfo] = {}
    for comp in system.components:
        node = snap.nodes.get(f"{snap.namespace}/{comp.name}")
        if node is not None and node.component in (None, comp.name):
            found[comp.name] = node
            continue
        claiming = [n for n in snap.nodes.values() if n.component == comp.name]
        if len(claiming) == 1:
            found[comp.name] = claiming[0]
    return found


def drift(system: System, snap: Snapshot) -> list[Diagnostic]:
    """Every difference between `system`'s deployed configuration and `snap`."""
    nodes = locate(system, snap)
    config = Configuration.initial(system)
    out: list[Diagnostic] = []
    for comp in system.components:
        node = nodes.get(comp.name)
        if node is None:
            out.append(_d("RC611", f"component {comp.name} has no node in the live system (no node "
                                   f"{snap.namespace}/{comp.name}, none declares it)", comp.span))
        elif node.lifecycle is not None and node.lifecycle != "active":
            out.append(_d("RC617", f"{comp.name}'s node {node.fqn} is {node.lifecycle}, not active", comp.span,
                          "an inactive node is isolated: its attachments and modes are not compared"))
        else:
            out += _modes(comp, node) + _ports(system, config, comp, node)
    out += _extra(system, snap, nodes) + _types(system, snap) + _single(system, snap)
    return sorted(out, key=lambda d: (d.span.file, d.span.line, d.span.col, d.code, d.message))


def _modes(comp: Component, node: NodeInfo) -> list[Diagnostic]:
    out = []
    for f in comp.functionalities:
        live = node.modes.get(f.name)
        if live is not None and live != "normal":
            out.append(_d("RC615", f"{comp.name}.{f.name} is {live} live; the deployed configuration has it normal",
                          f.span))
    return out


def _role_span(system: System, conn: str, comp: str, port: str) -> Optional[Span]:
    c = system.connector(conn)
    return next((r.span for r in c.roles if r.component == comp and r.port == port), None) if c else None


def _ports(system: System, config: Configuration, comp: Component, node: NodeInfo) -> list[Diagnostic]:
    """Attachments, per port from the node's `reconf.port.*` parameters; for a node without them
    (not a reconf node), per direction from its topics and services."""
    if node.model is None:
        return _endpoints(system, config, comp, node)
    out = []
    for port in comp.ports:
        if port.name not in node.ports:
            out.append(_d("RC613", f"{comp.name}'s node {node.fqn} has no port {port.name} (no parameter "
                                   f"reconf.port.{port.name})", port.span))
            continue
        want, live = set(config.connector_of(comp.name, port.name)), set(node.ports[port.name])
        out += _port_diff(system, f"{comp.name}.{port.name}", want - live, live - want,
                          lambda k: _role_span(system, k, comp.name, port.name) or port.span, port.span)
    return out


def _port_diff(system: System, what: str, missing: set[str], extra: set[str], span_of: Callable[[str], Span],
               port_span: Span) -> list[Diagnostic]:
    def elsewhere(k: str) -> str:
        return k if system.connector(k) is not None else f"{k} (not a connector of the model)"
    if missing and extra:
        return [_d("RC613", f"{what} is attached to {', '.join(elsewhere(k) for k in sorted(extra))}, where the model "
                            f"attaches it to {', '.join(sorted(missing))}", span_of(sorted(missing)[0]))]
    return [_d("RC613", f"{what} is not attached to {k} live", span_of(k)) for k in sorted(missing)] + \
           [_d("RC613", f"{what} is attached to {elsewhere(k)} live, which the model does not attach it to", port_span)
            for k in sorted(extra)]



def _endpoints(system: System, config: Configuration, comp: Component, node: NodeInfo) -> list[Diagnostic]:
    out = []
    for side, live in (("publishes", set(node.publishers) | set(node.servers)),
                       ("subscribes", set(node.subscribers) | set(node.clients))):
        want = {c.name for c in system.connectors for r in (c.publishers if side == "publishes" else c.subscribers)
                if r.component == comp.name and (c.name, comp.name, r.port) in config.roles}
        out += _port_diff(system, f"{comp.name} ({side}, a node without reconf.model)", want - live, live - want,
                          lambda k: next((r.span for c in system.connectors if c.name == k for r in c.roles
                                          if r.component == comp.name), comp.span), comp.span)
    return out


def _extra(system: System, snap: Snapshot, nodes: dict[str, NodeInfo]) -> list[Diagnostic]:
    """Nodes no deployed component accounts for; nodes with no topic or service of the
    application (tools such as a status watcher) are not part of the system."""
    placed = {n.fqn for n in nodes.values()}
    versions = {v.name for v in system.versions}
    out = []
    for fqn, node in sorted(snap.nodes.items()):
        if fqn in placed or not (node.has_endpoints or node.model is not None):
            continue
        declared = node.component or node.name
        why = f" (a version of the model, `{declared}`, not deployed)" if declared in versions else ""
        out.append(_d("RC612", f"node {fqn} runs but no deployed component of {system.name} is it{why}",
                      system.span, *_endpoint_notes(node)))
    return out


def _endpoint_notes(node: NodeInfo) -> list[str]:
    notes = []
    for what, eps in (("publishes", node.publishers), ("subscribes to", node.subscribers),
                      ("serves", node.servers), ("calls", node.clients)):
        if eps:
            notes.append(f"it {what} {', '.join(sorted(eps))}")
    return notes


def _types(system: System, snap: Snapshot) -> list[Diagnostic]:
    out = []
    for conn in system.connectors:
        live = snap.topics.get(conn.name)
        msg = system.message(conn.guarantee.message) if conn.guarantee.message else None
        if not live or msg is None:
            continue
        if live != [msg.ros_type]:
            out.append(_d("RC614", f"{conn.name} carries {', '.join(live)} live; the model says {msg.ros_type} "
                                   f"({msg.name})", conn.guarantee.span or conn.span))
    return out


def _single(system: System, snap: Snapshot) -> list[Diagnostic]:
    out = []
    for conn in system.connectors:
        if not conn.single_publisher:
            continue
        pubs = snap.publishers(conn.name)
        if len(pubs) > 1:
            what = "service" if conn.kind == "service" else "single topic"
            out.append(_d("RC616", f"{conn.name} is a {what} but has {len(pubs)} publishers live: {', '.join(pubs)}",
                          conn.span))
    return out
