"""An architecture from a snapshot of the live system (`reconf_ros.executor.snapshot.Snapshot`), as `.arch`
text in the formatter's canonical layout (docs/runtime.md#discover). Pure Python: no ROS here.

A reconf node's component is its own model (`reconf.model`), exact; its attachments are its
`reconf.port.*` parameters. A node without a model gets a placeholder component from the graph:
its publishers as outputs, its subscribers as inputs (service servers and clients likewise), no
rates, one functionality `main`. A connector's guarantee is its message type at the highest
rate its publishers' normal modes guarantee. Every guess is marked `// placeholder: ...`, and
so is a node that did not answer. One ROS type has one alias: the models' own names first (a
model whose name is taken by another type, or who names a type already named, is written with
the name already in use), then the placeholders' (the type's last part, else package_Name).
A topic with subscribers and no publisher is written as it is, a placeholder, and not as an
`environment` guarantee: the graph cannot tell data from outside ROS from a publisher that is
missing, so `reconf check` says the subscribers' assumptions do not hold until one is added.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any, Optional

from checker.reality.node_text import parse_model
from checker.reality.unique_names import unique
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Severity
from reconf_dsl.formatter import format_document, pred
from reconf_dsl.ir import Component, Document, MessageType, Mode, Predicate
from reconf_dsl.parser import parse_text
from reconf_dsl.span import Span
from reconf_ros.executor.snapshot import NodeInfo, Snapshot

__all__ = ["architecture", "placeholders", "PLACEHOLDER"]

PLACEHOLDER = "// placeholder: "
ROS_NAME = re.compile(r"(/[^\W\d]\w*)+")


@dataclass
class _Role:
    component: str
    port: str
    output: bool
    alias: str
    predicate: Optional[Predicate] = None     # an output's normal guarantee, when a model says it


@dataclass
class _Build:
    messages: dict[str, str] = field(default_factory=dict)          # alias -> ROS type
    blocks: list[str] = field(default_factory=list)
    roles: dict[str, list[_Role]] = field(default_factory=dict)     # connector -> roles
    services: set[str] = field(default_factory=set)
    environment: dict[str, Predicate] = field(default_factory=dict)  # alias -> the most any model assumes of it

    def alias(self, ros_type: str, wanted: str = "") -> str:
        """The one alias of a ROS type: the one it has, else `wanted`, its last part, package_Name,
        package_Name_2, ... whichever is free first."""
        for a, t in self.messages.items():
            if t == ros_type:
                return a
        pkg, name = ros_type.split("/")[0], ros_type.rsplit("/", 1)[1]
        alias, k = next((a for a in (wanted, name) if a and a not in self.messages), f"{pkg}_{name}"), 2
        while alias in self.messages:
            alias, k = f"{pkg}_{name}_{k}", k + 1
        self.messages[alias] = ros_type
        return alias


def architecture(snap: Snapshot, system: str) -> str:
    """The snapshot as `.arch` text, canonical (reconf fmt)."""
    b = _Build()
    taken: set[str] = set()
    nodes = sorted(snap.nodes.values(), key=lambda n: n.fqn)
    blocks: dict[str, str] = {}
    for node in nodes:           # the models' message names first: their text uses them
        if node.model:
            _modelled(b, node, snap, taken)
            blocks[node.fqn] = b.blocks.pop()
    for node in nodes:
        if node.fqn not in blocks and (node.has_endpoints or node.unanswered):
            _plain(b, node, taken)
            blocks[node.fqn] = b.blocks.pop()
    b.blocks = [blocks[n.fqn] for n in nodes if n.fqn in blocks]
    text = "\n".join([f"system {system}", ""] + [f"message {a} = {t}" for a, t in sorted(b.messages.items())]
                     + [""] + _environment(b) + b.blocks + _connectors(b))
    try:
        return format_document(parse_text(text, "<discovered>"))
    except DiagnosticError:   # pragma: no cover - the text above is built to parse
        return text


def _unanswered(node: NodeInfo) -> str:
    return f"it did not answer: {node.unanswered}" if node.unanswered else ""


def placeholders(text: str, file: str) -> list[Diagnostic]:
    """One RC601 warning per `// placeholder:` comment of `text`, at its line."""
    out = []
    for i, line in enumerate(text.splitlines(), 1):
        col = line.find(PLACEHOLDER)
        if col >= 0:
            out.append(Diagnostic("RC601", Severity.WARNING, line[col + len(PLACEHOLDER):],
                                  Span(file, i, col + 1, i, len(line) + 1)))
    return out


def _modelled(b: _Build, node: NodeInfo, snap: Snapshot, taken: set[str]) -> None:
    model = node.model or ""
    parsed = parse_model(model, f"<{node.fqn} reconf.model>")
    if parsed is None or parsed[1].name in taken:
        _plain(b, node, taken, why="its reconf.model does not parse" if parsed is None
               else "its reconf.model has no component of its own")
        return
    doc, comp = parsed
    taken.add(comp.name)
    names = {m.name: b.alias(m.ros_type, m.name) for m in doc.items if isinstance(m, MessageType)}
    renamed = {a: n for a, n in names.items() if a != n}
    if renamed:
        comp = _renamed(comp, renamed)
        text = format_document(Document("<renamed>", None, (comp,)))
    else:
        text = model[model.index("component "):]
    live = [f"{f} {m}" for f, m in sorted(node.modes.items()) if m != "normal"]
    if node.lifecycle not in (None, "active"):
        live.insert(0, str(node.lifecycle))
    head = [f"// live: {', '.join(live)}"] if live else []
    if node.unanswered:
        head.append(f"{PLACEHOLDER}node {node.fqn}: {_unanswered(node)}; its modes and attachments are not known")
    b.blocks.append("\n".join(head) + "\n" + text)
    for f in comp.functionalities:      # what no input of f can satisfy is the environment's
        on_inputs = {p.message for p in comp.inputs if p.name in f.ports}
        for a in (f.normal.assumptions if f.normal else ()):
            if a.message and a.message not in on_inputs:
                known = b.environment.get(a.message)
                if known is None or (a.hz or 0) > (known.hz or 0):
                    b.environment[a.message] = a
    guarantees = {g.port: g.predicate for f in comp.functionalities if f.normal for g in f.normal.guarantees}
    for port in comp.ports:
        for k in node.ports.get(port.name, []):
            b.roles.setdefault(k, []).append(_Role(comp.name, port.name, port.kind == "output", port.message,
                                                   guarantees.get(port.name)))
            if f"{k}/request" in snap.topics:       # a reconf service: requests on <k>/request
                b.services.add(k)


def _renamed(comp: Component, names: dict[str, str]) -> Component:
    """`comp` with its message type aliases renamed."""
    def p(x: Any) -> Any:
        return x if x is None or x.message not in names else replace(x, message=names[x.message])

    def mode(m: Optional[Mode]) -> Optional[Mode]:
        return None if m is None else replace(m, assumptions=tuple(p(a) for a in m.assumptions),
                                              guarantees=tuple(replace(g, predicate=p(g.predicate))
                                                               for g in m.guarantees))
    ports = tuple(replace(q, message=names.get(q.message, q.message), assumption=p(q.assumption)) for q in comp.ports)
    funcs = tuple(replace(f, normal=mode(f.normal), degraded=mode(f.degraded)) for f in comp.functionalities)
    return replace(comp, ports=ports, functionalities=funcs)


def _name(text: str, used: set[str]) -> str:
    base = re.sub(r"\W", "_", text.strip("/")) or "port"
    base = base if re.match(r"[^\W\d]", base) else f"p_{base}"
    return unique(base, used)


def _plain(b: _Build, node: NodeInfo, taken: set[str], why: str = "") -> None:
    comp = _name(node.name, taken)
    lines: list[str] = []
    ports: list[str] = []
    outs: list[tuple[str, str]] = []
    used: set[str] = set()
    skipped: list[str] = []
    names: list[str] = []          # `port = /topic`: the node block's lines
    for eps, output in ((node.publishers, True), (node.servers, True), (node.subscribers, False),
                        (node.clients, False)):
        for k, types in sorted(eps.items()):
            if not ROS_NAME.fullmatch(k) or len(types) != 1 or "/_" in k:
                skipped.append(k)
                continue
            alias = b.alias(types[0])
            port = _name(k.rsplit("/", 1)[1], used)
            lines.append(f"  {'output' if output else 'input'} {port}: {alias}")
            names.append(f"    {port} = {k}")
            ports.append(port)
            if output:
                outs.append((port, alias))
            if eps is node.servers or eps is node.clients:
                b.services.add(k)
            b.roles.setdefault(k, []).append(_Role(comp, port, output, alias))
    inputs = [ln.split(": ")[1] for ln in lines if ln.startswith("  input")]
    normal = " ".join([f"assume {a}" for a in inputs] + [f"{p}: {a}" for p, a in outs])
    degraded = " ".join(f"{p}: nothing" for p, _ in outs)
    head = f"node {node.fqn} did not answer ({node.unanswered}), so what it is is not known" if node.unanswered \
        else f"node {node.fqn} has no reconf.model" + (f" ({why})" if why else "")
    block, said = _node_block(node, names, ports, b, why)
    note = head + \
        ": its topics as ports, no rates, one functionality" + said + \
        (f"; left out: {', '.join(skipped)}" if skipped else "")
    b.blocks.append("\n".join([PLACEHOLDER + note, f"component {comp} {{", *block, *lines,
                               f"  functionality main ({', '.join(ports)}) {{",
                               f"    normal {{ {normal} }}", f"    degraded {{ {degraded} }}", "  }", "}"]))


def _node_block(node: NodeInfo, names: list[str], ports: list[str], b: _Build, why: str) -> tuple[list[str], str]:
    """The `node` block of a node that is not a reconf node, so that reconf can drive it through
    an adapter once it knows how to start it (docs/adapter.md): its name, lifecycle or not, its
    topics' real names, and `main` degraded by deactivating a lifecycle node, else by holding
    its outputs back. None for a node that did not answer, is a reconf node whose model is
    unusable, or has services (an adapter relays topics)."""
    if node.unanswered or why or node.servers or node.clients:
        return [], ""
    lifecycle = node.lifecycle is not None
    effect = "deactivate" if lifecycle else "hold"
    block = [f"  node {node.name}{' lifecycle' if lifecycle else ''} {{", *names,
             *([f"    main degraded: {effect}"] if ports else []), "  }"]
    return block, "; driven through an adapter: add the `run` line that starts it"


def _environment(b: _Build) -> list[str]:
    """An environment guarantee per message type a functionality assumes of no input: the graph
    cannot show it, so it is written as what is assumed of it, a placeholder."""
    out = []
    for alias, p in sorted(b.environment.items()):
        out.append(f"{PLACEHOLDER}{alias} is assumed of the environment: guaranteed here as assumed, not seen")
        out.append(f"environment {alias.lower()}: {pred(p)}")
    return out + ([""] if out else [])


def _connectors(b: _Build) -> list[str]:
    out = []
    for k, roles in sorted(b.roles.items()):
        roles = sorted(roles, key=lambda r: (r.component, r.port))
        pubs, subs = [r for r in roles if r.output], [r for r in roles if not r.output]
        alias = (pubs or subs)[0].alias
        rated = [r.predicate for r in pubs if r.predicate is not None and r.predicate.rate is not None]
        best = max(rated, key=lambda p: p.hz or Fraction(0), default=None)
        guarantee = pred(best) if best is not None and best.message == alias else alias
        if not pubs:
            out.append(f"{PLACEHOLDER}{k} has " + ("clients and no server" if k in b.services
                                                   else "subscribers and no publisher") + " in the graph")
        elif not rated:
            out.append(f"{PLACEHOLDER}{k}: no publisher's model gives a rate")
        kind = "service" if k in b.services else "topic"
        refs = lambda rs: ", ".join(f"{r.component}.{r.port}" for r in rs)    # noqa: E731
        out.append(f"{kind} {k}: {guarantee} {{ {refs(pubs)} -> {refs(subs)} }}".replace("{  -> ", "{ -> ")
                   .replace(" ->  }", " -> }"))
    return out
