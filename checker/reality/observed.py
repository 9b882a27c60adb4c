"""The running system as a configuration of a model, for `reconf recover --live`
(docs/executor.md#recovering-from-the-live-system): each component's node found as a plan
script finds it (`reconf_ros.executor.status.find_node`), read as present (active), its modes
and attachments; and the nodes a plan started that no component of the model accounts for
(their status's `created` mark: docs/executor.md#names), its *orphans*.

An active orphan is part of the configuration: its component, as its `reconf.model` describes
it, joins the model under its node's name, so that the recovery plan adopts it (the target has
it) or takes it away (detached, degraded, removed). An orphan that is not active (a process
killed between its start and its activation) is in no configuration: it is ended before the
plan's first step, unless the target has its component, whose create then adopts it. Any other
node the model does not account for is left alone, and said so (RC631).

A node under a component's name that runs another definition of it (an older version a killed
transition left, which no plan marked as its own) is that component as it runs: its definition
takes the component's name in the model, and the model's own becomes its new version `X@new`
(`renames`), which the recovery creates beside it under a free name and which takes over as
a transition's new version does (docs/executor.md#names). Pure Python: the live system is a
`Snapshot` (`reconf_ros.executor.snapshot`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from fractions import Fraction
from typing import Any, Optional

from checker.reality.node_text import parse_model
from checker.reality.unique_names import unique
from checker.semantic_model.config import Configuration, FuncId, Role
from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.ir import Component, Connector, ConnectorKind, MessageType, Mode, Predicate, Rate, System
from reconf_dsl.span import Span
from reconf_ros.executor.snapshot import NodeInfo, Snapshot
from reconf_ros.executor.status import find_node

__all__ = ["LiveConfiguration", "NotReadable", "observed"]


class NotReadable(Exception):
    """A node of the model runs but could not be read (it did not answer): no plan can start
    from a configuration that is not known."""


@dataclass
class LiveConfiguration:
    """What runs, as a configuration of `system` (the model, with the active orphans' components
    added); `placed`: component -> its node's name where not its own; `orphans`: the nodes to
    end before the plan (docs/executor.md#recovering-from-the-live-system); `renames`: a
    component's new version -> the component, where a node runs another definition of it;
    `notes`: what was left alone, and why."""

    system: System
    config: Configuration
    placed: dict[str, str] = field(default_factory=dict)
    orphans: list[dict[str, Any]] = field(default_factory=list)
    renames: dict[str, str] = field(default_factory=dict)
    notes: list[Diagnostic] = field(default_factory=list)

    def retarget(self, target: Configuration) -> Configuration:
        """`target` (a configuration of the model) in this system's names: a component another
        definition of which runs is its new version there."""
        new = {old: version for version, old in self.renames.items()}
        return Configuration(frozenset(new.get(c, c) for c in target.components),
                             frozenset((new.get(c, c), f) for c, f in target.degraded),
                             frozenset((k, new.get(c, c), p) for k, c, p in target.roles))


def _locate(system: System, snap: Snapshot) -> dict[str, NodeInfo]:
    """Each component's node, deployed components first, then the versions (a new version that
    a plan started runs under its own name, or declares its component in its status). A node
    that runs another component (other functionalities or ports: a new version of it, say) is
    not its node; a finalized one is gone."""
    statuses = {f: {"component": n.component} for f, n in snap.nodes.items() if n.component}
    found: dict[str, NodeInfo] = {}
    graph = {f for f, n in snap.nodes.items() if n.lifecycle != "finalized"}
    for comp in system.components + system.versions:
        fits = {f for f in graph if _runs(comp, snap.nodes[f])}
        fqn = find_node(f"{snap.namespace}/{comp.name}", comp.name, fits, statuses,
                        {n.fqn for n in found.values()})
        if fqn is not None:
            found[comp.name] = snap.nodes[fqn]
    return found


def _runs(comp: Component, node: NodeInfo) -> bool:
    """Whether `node` can be `comp`'s: its model, if it shows one, has comp's functionalities
    and ports (what a configuration reads of it)."""
    if not node.model:
        return True
    parsed = parse_model(node.model, f"<{node.fqn} reconf.model>")
    if parsed is None:
        return True          # read as it is: what it lacks is said when it is read
    live = parsed[1]
    return {f.name for f in live.functionalities} == {f.name for f in comp.functionalities} and \
        {p.name for p in live.ports} == {p.name for p in comp.ports}


def _read(comp: Component, node: NodeInfo) -> tuple[list[FuncId], list[Role]]:
    """The degraded functionalities and the attachments a present component's node shows."""
    if node.unanswered:
        raise NotReadable(f"{comp.name}'s node {node.fqn} does not answer ({node.unanswered})")
    missing = [f"reconf.mode.{f.name}" for f in comp.functionalities if f.name not in node.modes] + \
        [f"reconf.port.{p.name}" for p in comp.ports if p.name not in node.ports]
    if missing:
        raise NotReadable(f"{comp.name}'s node {node.fqn} does not show {', '.join(missing)}")
    degraded = [(comp.name, f.name) for f in comp.functionalities if node.modes[f.name] != "normal"]
    roles = [(k, comp.name, p.name) for p in comp.ports for k in node.ports[p.name]]
    return degraded, roles


def _orphan(node: NodeInfo, why: str) -> dict[str, Any]:
    return {"node": node.fqn, "component": node.component or "", "pid": node.pid, "lifecycle": node.lifecycle,
            "created": node.created or "", "why": why}


def observed(system: System, snap: Snapshot, target: Configuration) -> LiveConfiguration:
    """`snap` as a configuration of `system`; `target` says which inactive nodes a plan adopts
    (their component is created there) rather than ends. Raises NotReadable when a node of the
    model runs and does not answer."""
    live = LiveConfiguration(system, Configuration(frozenset(), frozenset(), frozenset()))
    comps: set[str] = set()
    degraded: list[FuncId] = []
    roles: list[Role] = []
    nodes = _locate(system, snap)
    for name, node in nodes.items():
        comp = system.component(name)
        assert comp is not None
        if node.name != name:
            live.placed[name] = node.name
        if node.lifecycle == "unresponsive":      # in the graph, not answering: never taken for absent
            raise NotReadable(f"{name}'s node {node.fqn} does not answer ({node.unanswered or 'get_state'})")
        if node.lifecycle == "active":
            _join(comp, node, comps, degraded, roles)
        elif node.created and name not in target.components:
            live.orphans.append(_orphan(node, f"a plan started it for {name}, which the target does not have, "
                                              f"and it is {node.lifecycle}"))
    placed = {n.fqn for n in nodes.values()}
    for node in sorted(snap.nodes.values(), key=lambda n: n.fqn):
        if node.fqn not in placed and node.lifecycle != "finalized" and \
                not _superseded(live, node, set(nodes), comps, degraded, roles):
            _unaccounted(live, node, comps, degraded, roles)
    system = _with_connectors(live.system, snap, roles)
    live.system = system
    live.config = Configuration(frozenset(comps), frozenset(degraded), frozenset(roles))
    return live


def _unaccounted(live: LiveConfiguration, node: NodeInfo, comps: set[str], degraded: list[FuncId],
                 roles: list[Role]) -> None:
    """A node no component of the model accounts for: an orphan of a plan joins the
    configuration (active) or is ended (not active); any other is left alone."""
    if not node.created or node.model is None:
        if node.has_endpoints:
            live.notes.append(_note(f"{node.fqn} is not a component of the model and no plan started it: left alone"))
        return
    if node.lifecycle != "active":
        live.orphans.append(_orphan(node, f"a plan started it and it is {node.lifecycle}"))
        return
    parsed = parse_model(node.model, f"<{node.fqn} reconf.model>")
    if parsed is None or node.unanswered:
        raise NotReadable(f"{node.fqn}, which a plan started, does not answer or runs a model that does not parse"
                          f"{' (' + node.unanswered + ')' if node.unanswered else ''}")
    comp = _beside(live, node, parsed[0].items, dc_replace(parsed[1], name=unique(node.name, _taken(live.system))))
    _join(comp, node, comps, degraded, roles)


def _taken(system: System) -> set[str]:
    return {c.name for c in system.components + system.versions}


def _beside(live: LiveConfiguration, node: NodeInfo, items: Any, runs: Component) -> Component:
    """`runs` (what `node` runs, under a name of its own) joins the model as a version placed
    at `node`."""
    live.system, comp = _adopted(live.system, items, dc_replace(runs, replaces=None))
    live.placed[comp.name] = node.name
    return comp


def _join(comp: Component, node: NodeInfo, comps: set[str], degraded: list[FuncId], roles: list[Role]) -> None:
    """`comp`, read from its active `node`, is present with the modes and attachments shown."""
    comps.add(comp.name)
    d, r = _read(comp, node)
    degraded += d
    roles += r


def _superseded(live: LiveConfiguration, node: NodeInfo, located: set[str], comps: set[str],
                degraded: list[FuncId], roles: list[Role]) -> bool:
    """Whether `node`, active under the name of a component X of the model, runs another
    definition of it (one that parses), which it then is: X as it runs, and the model's
    definition its new version `X@new`, when no other node was found for X; else (X's new
    version runs elsewhere, a killed transition's) an older definition beside it, `X@old`,
    which the target does not have."""
    comp = live.system.component(node.name)
    if comp is None or comp.replaces or node.lifecycle != "active" or not node.model or node.unanswered:
        return False
    parsed = parse_model(node.model, f"<{node.fqn} reconf.model>")
    if parsed is None:
        return False
    if node.name in located:
        name = unique(f"{comp.name}@old", _taken(live.system))
        running = _beside(live, node, parsed[0].items, dc_replace(parsed[1], name=name, host=comp.host, run=comp.run))
        live.notes.append(_note(f"{node.fqn} runs an older definition of {comp.name}, whose node is "
                                f"{live.placed.get(comp.name, comp.name)}: it is {name}, which the target does not have",
                                "RC633"))
    else:
        running = _supersede(live, comp, parsed[0].items, parsed[1], node)
    _join(running, node, comps, degraded, roles)
    return True


def _supersede(live: LiveConfiguration, comp: Component, items: Any, runs: Component, node: NodeInfo) -> Component:
    """`comp` as `node` runs it (`runs`), the model's definition its new version: the first."""
    version = unique(f"{comp.name}@new", _taken(live.system))
    system, running = _adopted(live.system, items, dc_replace(runs, name=comp.name, replaces=None,
                                                              host=comp.host, run=comp.run))
    live.system = dc_replace(system, components=tuple(running if c.name == comp.name else c for c in system.components),
                             versions=tuple(v for v in system.versions if v is not running) +
                             (dc_replace(comp, name=version, replaces=comp.name),))
    live.renames[version] = comp.name
    live.notes.append(_note(f"{node.fqn} runs another definition of {comp.name} than the model's: it is "
                            f"{comp.name} as it runs, and the model's {comp.name} is created beside it as {version}",
                            "RC633"))
    return running


def _note(text: str, code: str = "RC631") -> Diagnostic:
    return Diagnostic(code, Severity.WARNING, text, Span.unknown("<ros>"))


def _adopted(system: System, items: Any, comp: Component) -> tuple[System, Component]:
    """`system` with `comp` as a version, its message types named as `system` names them: the
    same name for the same ROS type, else the first name `system` gives that type (several names
    may share one ROS type: an FTM's messages are all std_msgs/msg/String); a type `system`
    lacks is added under a free name."""
    ours: dict[str, str] = {}
    for m in system.messages:
        ours.setdefault(m.ros_type, m.name)
    same = {(m.name, m.ros_type) for m in system.messages}
    messages = list(system.messages)
    names: dict[str, str] = {}
    for m in (it for it in items if isinstance(it, MessageType)):
        if (m.name, m.ros_type) in same:
            names[m.name] = m.name
            continue
        if m.ros_type not in ours:
            ours[m.ros_type] = unique(m.name, {x.name for x in messages})
            messages.append(MessageType(ours[m.ros_type], m.ros_type))
        names[m.name] = ours[m.ros_type]
    comp = _renamed(comp, names)
    return dc_replace(system, messages=tuple(messages), versions=system.versions + (comp,)), comp


def _renamed(comp: Component, names: dict[str, str]) -> Component:
    def p(x: Optional[Predicate]) -> Optional[Predicate]:
        return x if x is None or x.message not in names else dc_replace(x, message=names[x.message])

    def mode(m: Optional[Mode]) -> Optional[Mode]:
        return None if m is None else dc_replace(
            m, assumptions=tuple(q for q in (p(a) for a in m.assumptions) if q is not None),
            guarantees=tuple(dc_replace(g, predicate=p(g.predicate) or g.predicate) for g in m.guarantees))
    ports = tuple(dc_replace(q, message=names.get(q.message, q.message), assumption=p(q.assumption))
                  for q in comp.ports)
    funcs = tuple(dc_replace(f, normal=mode(f.normal), degraded=mode(f.degraded)) for f in comp.functionalities)
    return dc_replace(comp, ports=ports, functionalities=funcs)


def _with_connectors(system: System, snap: Snapshot, roles: list[Role]) -> System:
    """`system` with a connector for each name a node is attached to that the model lacks: a
    topic of its publishers' type guaranteeing the highest rate their normal modes promise
    (as `reconf discover` writes it), so that what is attached there can be taken away."""
    known = {k.name for k in system.connectors}
    extra: dict[str, list[tuple[str, str]]] = {}
    for k, c, p in roles:
        if k not in known:
            extra.setdefault(k, []).append((c, p))
    added = []
    for k, ends in sorted(extra.items()):
        ports = [(c, port) for c, p in ends if (comp := system.component(c)) and (port := comp.port(p))]
        if not ports:
            continue
        message = ports[0][1].message
        best: Optional[Fraction] = None
        for c, port in ports:
            comp = system.component(c)
            for f in comp.functionalities if comp and port.kind == "output" else ():
                g = f.normal.guarantee(port.name) if f.normal is not None and port.name in f.ports else None
                if g is not None and g.message == message and g.hz is not None:
                    best = g.hz if best is None else max(best, g.hz)
        rate = None if best is None else Rate(best, "Hz")
        kind: ConnectorKind = "service" if f"{k}/request" in snap.topics else "topic"
        added.append(Connector(k, kind, Predicate(message, rate)))  # attachments: the configuration's
    return dc_replace(system, connectors=system.connectors + tuple(added)) if added else system
