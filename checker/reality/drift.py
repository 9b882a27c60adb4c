"""Drift: the model's deployed configuration against a snapshot of the running system
(`reconf_ros.executor.snapshot.Snapshot`), each difference a diagnostic at the model's span. Pure Python:
no ROS here (docs/runtime.md#drift).

The deployed configuration is what `reconf up` brings the system to (`up_state`): every
component present and active with the model's own `reconf.model`, every declared attachment in
place and no other, every functionality normal but those whose assumptions cannot hold there.
"""
from __future__ import annotations

from typing import Callable, Optional

from checker.planning.bringup import up_state
from checker.reality.node_text import parse_model
from checker.semantic_model.actions import failing_assumptions
from checker.semantic_model.config import Configuration
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import Component, MessageType, Mode, Predicate, System, format_number
from reconf_dsl.span import Span
from reconf_ros.executor.snapshot import NodeInfo, Snapshot
from reconf_ros.executor.status import find_node

__all__ = ["drift", "deployed", "locate", "KINDS"]

KINDS = {"RC611": "component missing", "RC612": "component extra", "RC613": "attachment",
         "RC614": "message type", "RC615": "mode", "RC616": "publishers on a single connector",
         "RC617": "lifecycle", "RC618": "model", "RC619": "no control interface"}


def _d(code: str, message: str, span: Span, *notes: str) -> Diagnostic:
    return Diagnostic(code, Severity.ERROR, message, span, notes=tuple(notes))


def locate(system: System, snap: Snapshot) -> dict[str, NodeInfo]:
    """Each deployed component's node, found as a plan script finds it (`find_node`): the node
    named after it, unless that node declares another component, else the one node that declares
    it (a new version's node, `X_2`; docs/executor.md#names)."""
    statuses = {f: {"component": n.component} for f, n in snap.nodes.items() if n.component}
    found: dict[str, NodeInfo] = {}
    for comp in system.components:
        fqn = find_node(f"{snap.namespace}/{comp.name}", comp.name, set(snap.nodes), statuses,
                        {n.fqn for n in found.values()})
        if fqn is not None:
            found[comp.name] = snap.nodes[fqn]
    return found


def deployed(system: System) -> tuple[Configuration, list[str]]:
    """What the system is compared with, `up_state` (what `reconf up` brings it to), and a note
    for each functionality that leaves degraded, saying why."""
    config = up_state(system)
    failing = {(c, f): a for c, f, a in failing_assumptions(system, Configuration.initial(system))}
    notes = [f"{c}.{f} is degraded as deployed: " +
             (f"it assumes {failing[(c, f)]}, which cannot hold there" if (c, f) in failing
              else "what it assumes is no longer provided once the others are degraded")
             for c, f in sorted(config.degraded)]
    return config, notes


def drift(system: System, snap: Snapshot) -> list[Diagnostic]:
    """Every difference between `system`'s deployed configuration and `snap`."""
    nodes = locate(system, snap)
    config, _ = deployed(system)
    out: list[Diagnostic] = []
    for comp in system.components:
        node = nodes.get(comp.name)
        if node is None:
            out.append(_d("RC611", f"component {comp.name} has no node in the live system (no node "
                                   f"{snap.namespace}/{comp.name}, none declares it)", comp.span))
        elif node.unanswered:
            out.append(_d("RC617", f"{comp.name}'s node {node.fqn} does not answer ({node.unanswered})", comp.span,
                          "nothing of a node that does not answer is compared"))
        elif node.lifecycle is not None and node.lifecycle != "active":
            out.append(_d("RC617", f"{comp.name}'s node {node.fqn} is {node.lifecycle}, not active", comp.span,
                          "an inactive node is isolated: its attachments and modes are not compared"))
        else:
            if node.model is None:
                out.append(_uncontrolled(comp, node))
            live = _model(system, comp, node, out)
            out += _modes(config, comp, node) + _ports(system, config, comp, node, live)
    out += _extra(system, snap, nodes) + _types(system, snap) + _single(system, snap)
    return sorted(out, key=lambda d: (d.span.file, d.span.line, d.span.col, d.code, d.message))


def _uncontrolled(comp: Component, node: NodeInfo) -> Diagnostic:
    """RC619: the node that stands for `comp` has no control interface, so its modes and
    attachments are not known (its topics are still compared)."""
    why = ("it runs without its adapter: start it as the model does (`reconf up`, or `reconf-node --arch`), "
           "which renames the node and relays its topics" if comp.node is not None else
           "it is not a reconf node: declare how reconf drives it with a `node` block (docs/adapter.md)")
    return _d("RC619", f"{comp.name}'s node {node.fqn} does not implement the control interface (no reconf.model): "
                       "its modes and attachments cannot be read", comp.span, why)


def _modes(config: Configuration, comp: Component, node: NodeInfo) -> list[Diagnostic]:
    out = []
    for f in comp.functionalities:
        live, want = node.modes.get(f.name), "degraded" if (comp.name, f.name) in config.degraded else "normal"
        if live is not None and live != want:
            out.append(_d("RC615", f"{comp.name}.{f.name} is {live} live; the deployed configuration has it {want}",
                          f.span))
    return out


def _model(system: System, comp: Component, node: NodeInfo, out: list[Diagnostic]) -> Optional[Component]:
    """RC618 where the node's reconf.model is not `comp` (message types by their ROS type, rates
    by their value in Hz); the node's component, if its model parses."""
    if node.model is None:
        return None
    parsed = parse_model(node.model, f"<{node.fqn} reconf.model>")
    if parsed is None:
        out.append(_d("RC618", f"{comp.name}'s node {node.fqn} runs a reconf.model that does not parse as a "
                               "component", comp.span))
        return None
    doc, live = parsed
    types = {m.name: m.ros_type for m in doc.items if isinstance(m, MessageType)}
    ours = {m.name: m.ros_type for m in system.messages}
    differ = [f"{what}: the model has {a or 'none'}, the node {b or 'none'}"
              for what, a, b in _compared(comp, ours, live, types) if a != b]
    if differ:
        out.append(_d("RC618", f"{comp.name}'s node {node.fqn} runs another model: " + "; ".join(differ), comp.span,
                      "it is compared as it runs; a plan or `reconf up` starts the model's own"))
    return live


def _compared(model: Component, types: dict[str, str], live: Component,
              live_types: dict[str, str]) -> list[tuple[str, str, str]]:
    """(what, as the model has it, as the node has it) for every port and functionality of either."""
    def pred(p: Optional[Predicate], t: dict[str, str]) -> str:
        if p is None or p.message is None:
            return "nothing" if p is not None else ""
        return t.get(p.message, p.message) + (f" @ {format_number(p.hz)} Hz" if p.hz is not None else "")

    def port(c: Component, name: str, t: dict[str, str]) -> str:
        p = c.port(name)
        if p is None:
            return ""
        assume = f" assuming {pred(p.assumption, t)}" if p.assumption is not None else ""
        return f"{p.kind} {t.get(p.message, p.message)}{assume}"

    def mode(m: Optional[Mode], t: dict[str, str]) -> str:
        if m is None:
            return "-"
        return ", ".join(sorted([f"assume {pred(a, t)}" for a in m.assumptions] +
                                [f"{g.port}: {pred(g.predicate, t)}" for g in m.guarantees])) or "{}"

    def func(c: Component, name: str, t: dict[str, str]) -> str:
        f = next((f for f in c.functionalities if f.name == name), None)
        return "" if f is None else \
            f"({', '.join(sorted(f.ports))}) normal {{{mode(f.normal, t)}}} degraded {{{mode(f.degraded, t)}}}"
    ports = sorted({p.name for p in model.ports} | {p.name for p in live.ports})
    funcs = sorted({f.name for f in model.functionalities} | {f.name for f in live.functionalities})
    return [(f"port {n}", port(model, n, types), port(live, n, live_types)) for n in ports] + \
        [(f"functionality {n}", func(model, n, types), func(live, n, live_types)) for n in funcs]


def _role_span(system: System, conn: str, comp: str, port: str) -> Optional[Span]:
    c = system.connector(conn)
    return next((r.span for r in c.roles if r.component == comp and r.port == port), None) if c else None


def _ports(system: System, config: Configuration, comp: Component, node: NodeInfo,
           running: Optional[Component]) -> list[Diagnostic]:
    """Attachments, per port from the node's `reconf.port.*` parameters (a port its model lacks is
    RC618's); for a node without them (not a reconf node), per direction from its topics and services."""
    if node.model is None:
        return _endpoints(system, config, comp, node)
    out = []
    for port in comp.ports:
        if running is not None and running.port(port.name) is None:
            continue
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
        silent = [f"it does not answer ({node.unanswered})"] if node.unanswered else []
        out.append(_d("RC612", f"node {fqn} runs but no deployed component of {system.name} is it{why}",
                      system.span, *_endpoint_notes(node), *silent))
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
    for conn in system.connectors:     # a topic, a reconf service's replies, or a ROS service by its servers
        live = snap.topics.get(conn.name) or sorted({t for n in snap.nodes.values() for eps in (n.servers, n.clients)
                                                     for t in eps.get(conn.name, [])})
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
        pubs = sorted(set(snap.publishers(conn.name)) | {n.fqn for n in snap.nodes.values() if conn.name in n.servers})
        if len(pubs) > 1:
            what = "service" if conn.kind == "service" else "single topic"
            out.append(_d("RC616", f"{conn.name} is a {what} but has {len(pubs)} publishers live: {', '.join(pubs)}",
                          conn.span))
    return out
