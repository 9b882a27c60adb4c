"""Merge documents into a `System` and report every static problem (RC1xx).

Static means: judged from the text alone, with no notion of which assumptions hold.
"""
from __future__ import annotations

from typing import Iterable, Optional, TypeVar

from . import ir
from .diagnostics import DiagnosticError, DiagnosticSink, Related, error, shorten
from .span import Span

KNOWN_FTMS = {"PBR", "LFR", "TR", "AD", "SEC"}
KNOWN_FAULTS = {"crash", "transient", "permanent_value", "omission", "intrusion"}
KNOWN_APPLICATION = {"deterministic", "non_deterministic", "state_access", "no_state_access"}
KNOWN_RESOURCES = {"bandwidth": {"nil", "low", "medium", "high"}, "cpus": None, "memory": None}
MAX_RESOURCE_DIGITS = 18  # a whole number, so that reading it (int) is never the slow or failing part

T = TypeVar("T")


def resolve(docs: list[ir.Document]) -> ir.System:
    sink = DiagnosticSink()
    name, span = _system_name(docs, sink)
    items = [it for d in docs for it in d.items if not isinstance(it, ir.Include)]
    messages = [i for i in items if isinstance(i, ir.MessageType)]
    env = [i for i in items if isinstance(i, ir.EnvGuarantee)]
    comps = [i for i in items if isinstance(i, ir.Component)]
    conns = [i for i in items if isinstance(i, ir.Connector)]
    hosts = [i for i in items if isinstance(i, ir.Host)]

    for kind, group in (("message type", messages), ("environment guarantee", env), ("component", comps),
                        ("connector", conns), ("host", hosts)):
        _unique(sink, kind, group)
    msg_names = {m.name for m in messages}
    host_names = {h.name for h in hosts}
    for h in hosts:
        _check_resources(sink, h.resources)
    for e in env:
        _check_predicate(sink, e.guarantee, msg_names)
    by_name = {c.name: c for c in comps}
    for c in comps:
        _check_component(sink, c, msg_names, host_names, by_name)
    versions = {c.name for c in comps if c.replaces}
    attached: dict[tuple[str, str], ir.Connector] = {}
    for conn in conns:
        _check_connector(sink, conn, msg_names, by_name, versions, attached)
    sink.raise_if_errors()
    deployed = tuple(c for c in comps if c.replaces is None)
    return ir.System(name, tuple(messages), tuple(env), deployed, tuple(c for c in comps if c.replaces),
                     tuple(conns), tuple(hosts), tuple(d.file for d in docs), span)


def _system_name(docs: list[ir.Document], sink: DiagnosticSink) -> tuple[str, Span]:
    named = [(d.system, d.system_span) for d in docs if d.system is not None]
    if not named:
        sink.add(error("RC115", "no `system NAME` declaration", Span(docs[0].file, 1, 1, 1, 1) if docs
                       else Span.unknown(), notes=("an architecture starts with `system NAME`",)))
        sink.raise_if_errors()
    first, first_span = named[0]
    for other, span in named[1:]:
        if other != first:
            sink.add(error("RC115", f"files disagree on the system's name: '{other}' here, '{first}' before",
                           span, related=(Related(first_span, "first named here"),)))
    return first or "", first_span


def _unique(sink: DiagnosticSink, kind: str, items: Iterable[T], where: str = "") -> dict[str, T]:
    seen: dict[str, T] = {}
    for it in items:
        name: str = getattr(it, "name")
        span: Span = getattr(it, "span")
        if name in seen:
            sink.add(error("RC102", f"duplicate {kind} '{name}'{where}", span,
                           related=(Related(getattr(seen[name], "span"), "first declared here"),)))
        else:
            seen[name] = it
    return seen


def _check_predicate(sink: DiagnosticSink, p: ir.Predicate, msgs: set[str]) -> None:
    if p.message is not None and p.message not in msgs:
        sink.add(error("RC101", f"unknown message type '{p.message}'", p.span,
                       notes=(_suggest(p.message, msgs, "declare it with `message NAME = pkg/msg/Type`"),)))


def _suggest(name: str, known: Iterable[str], fallback: str) -> str:
    import difflib
    close = difflib.get_close_matches(name, sorted(known), n=1)
    return f"did you mean '{close[0]}'?" if close else fallback


def _check_resources(sink: DiagnosticSink, settings: Iterable[ir.ResourceSetting]) -> None:
    for r in settings:
        if r.name not in KNOWN_RESOURCES:
            sink.add(error("RC125", f"unknown resource '{r.name}'", r.span,
                           notes=("known resources: " + ", ".join(sorted(KNOWN_RESOURCES)),)))
            continue
        allowed = KNOWN_RESOURCES[r.name]
        digits = r.value.isascii() and r.value.isdigit()        # not `²`, which isdigit() accepts
        if allowed is None and not (digits and len(r.value) <= MAX_RESOURCE_DIGITS):
            shown = shorten(r.value, MAX_RESOURCE_DIGITS)
            sink.add(error("RC125", f"resource '{r.name}' takes a whole number of at most {MAX_RESOURCE_DIGITS} "
                                    f"digits, not '{shown}'", r.span))
        elif allowed is not None and r.value not in allowed:
            sink.add(error("RC125", f"resource '{r.name}' is one of {', '.join(sorted(allowed))}, not '{r.value}'",
                           r.span))


def _check_component(sink: DiagnosticSink, c: ir.Component, msgs: set[str], hosts: set[str],
                     comps: dict[str, ir.Component]) -> None:
    ports = _unique(sink, "port", c.ports, f" in component '{c.name}'")
    _unique(sink, "functionality", c.functionalities, f" in component '{c.name}'")
    for p in c.ports:
        if p.kind == "output" and p.name == "assume":
            sink.add(error("RC127", "an output cannot be named 'assume': in a mode, `assume` starts an assumption",
                           p.span))
        if p.kind == "output" and p.message not in msgs:
            sink.add(error("RC101", f"unknown message type '{p.message}'", p.span,
                           notes=(_suggest(p.message, msgs, "declare it with `message NAME = pkg/msg/Type`"),)))
        if p.assumption is not None:
            _check_predicate(sink, p.assumption, msgs)
    if c.replaces is not None:
        target = comps.get(c.replaces)
        if target is None or target is c:
            sink.add(error("RC118", f"'{c.name}' replaces unknown component '{c.replaces}'", c.span))
        elif target.replaces is not None:
            sink.add(error("RC118", f"'{c.name}' replaces '{c.replaces}', which is itself a replacement version",
                           c.span))
    if c.host is not None and hosts and c.host not in hosts:
        sink.add(error("RC101", f"unknown host '{c.host}'", c.span, notes=(_suggest(c.host, hosts, ""),)))
    for f in c.faults:
        if f not in KNOWN_FAULTS:
            sink.add(error("RC124", f"unknown fault '{f}'", c.span, notes=("known faults: " + ", ".join(sorted(KNOWN_FAULTS)),)))
    for a in c.application:
        if a not in KNOWN_APPLICATION:
            sink.add(error("RC124", f"unknown application characteristic '{a}'", c.span,
                           notes=("known: " + ", ".join(sorted(KNOWN_APPLICATION)),)))
    _check_resources(sink, c.resources)
    timed: dict[str, ir.Take] = {}
    for t in c.takes:
        if t.action in timed:
            sink.add(error("RC133", f"'{t.action}' is timed twice in component '{c.name}'", t.span,
                           related=(Related(timed[t.action].span, "the first time"),)))
        timed.setdefault(t.action, t)
    if c.ftm is not None:
        e: Optional[ir.FtmExpr] = c.ftm.expr
        while e is not None:
            if e.name not in KNOWN_FTMS:
                sink.add(error("RC124", f"unknown fault-tolerance mechanism '{e.name}'", e.span,
                               notes=("known: " + ", ".join(sorted(KNOWN_FTMS)),)))
            e = e.inner
        for h in c.ftm.hosts:
            if hosts and h not in hosts:
                sink.add(error("RC101", f"unknown host '{h}'", c.ftm.span))
    for func in c.functionalities:
        _check_functionality(sink, c, func, ports, msgs)
    if c.node is not None:
        _check_node(sink, c, c.node, ports)


def _check_node(sink: DiagnosticSink, c: ir.Component, node: ir.RosNode, ports: dict[str, ir.Port]) -> None:
    """A `node` block: every port has one ROS name of its own, every mode line is about a
    functionality of the component and does what its node can (docs/adapter.md#declaring-one)."""
    named: dict[str, ir.NodeTopic] = {}
    by_ros: dict[str, ir.NodeTopic] = {}
    for t in node.topics:
        if t.port not in ports:
            sink.add(error("RC128", f"the node block names port '{t.port}', which '{c.name}' does not have", t.span,
                           notes=(_suggest(t.port, ports, f"'{c.name}' declares: " + (", ".join(ports) or "no ports")),)))
        elif t.port in named:
            sink.add(error("RC129", f"port '{t.port}' is given two ROS names", t.span,
                           related=(Related(named[t.port].span, "first named here"),)))
        elif t.ros_name in by_ros:
            sink.add(error("RC129", f"ports '{by_ros[t.ros_name].port}' and '{t.port}' have one ROS name, "
                                    f"{t.ros_name}: remapping it moves both", t.span))
        else:
            named[t.port], by_ros[t.ros_name] = t, t
    for p in ports.values():
        if p.name not in named:
            sink.add(error("RC129", f"port '{p.name}' of '{c.name}' has no ROS name in its node block", p.span,
                           notes=(f"say what the node calls it, e.g. `{p.name} = /{p.name}`: reconf remaps that "
                                  "name to connect the port",)))
    _check_node_modes(sink, c, node)


def _check_node_modes(sink: DiagnosticSink, c: ir.Component, node: ir.RosNode) -> None:
    funcs = {f.name: f for f in c.functionalities}
    seen: dict[tuple[str, str], ir.NodeMode] = {}
    setters: dict[str, str] = {}            # parameter -> the functionality whose modes set it
    for m in node.modes:
        f = funcs.get(m.functionality)
        if f is None:
            sink.add(error("RC128", f"the node block names functionality '{m.functionality}', which '{c.name}' "
                                    "does not have", m.span, notes=(_suggest(m.functionality, funcs, "no such"),)))
            continue
        if (m.functionality, m.mode) in seen:
            sink.add(error("RC130", f"two lines for the {m.mode} mode of '{m.functionality}'", m.span,
                           related=(Related(seen[(m.functionality, m.mode)].span, "first here"),)))
            continue
        seen[(m.functionality, m.mode)] = m
        _check_effects(sink, c, node, f, m, setters)
    for (fname, mode), m in seen.items():
        other = "normal" if mode == "degraded" else "degraded"
        back = {e.param for e in node.effects(fname, other) if e.kind == "set"}
        for e in m.effects:
            if e.kind == "set" and e.param not in back:
                sink.add(error("RC131", f"the {mode} mode of '{fname}' sets parameter {e.param}, which its {other} "
                                        "mode does not set", e.span,
                               notes=(f"say its value in both modes (`{fname} {other}: set {e.param} = ...`), as "
                                      "system_modes does: each mode gives the node all of its values",)))


def _check_effects(sink: DiagnosticSink, c: ir.Component, node: ir.RosNode, f: ir.Functionality, m: ir.NodeMode,
                   setters: dict[str, str]) -> None:
    params: set[str] = set()
    for e in m.effects:
        if e.kind == "set":
            if e.param in params:
                sink.add(error("RC131", f"parameter {e.param} is set twice in one mode", e.span))
            elif setters.setdefault(e.param, f.name) != f.name:
                sink.add(error("RC131", f"parameter {e.param} is set by the modes of '{setters[e.param]}' and of "
                                        f"'{f.name}': which value holds would depend on the order of the steps",
                               e.span))
            params.add(e.param)
        elif m.mode == "normal":
            sink.add(error("RC130", f"`{e.kind}` in a normal mode: a normal mode runs the node as it is", e.span,
                           notes=(f"`{e.kind}` is what a degraded mode does",)))
        elif e.kind == "deactivate" and not node.lifecycle:
            sink.add(error("RC130", f"`deactivate` on node {node.name}, which is not declared a lifecycle node",
                           e.span, notes=(f"write `node {node.name} lifecycle` if it is one",)))
        elif e.kind == "deactivate":
            silenced = sorted(p.name for p in c.outputs if p.name not in f.ports)
            if silenced:
                sink.add(error("RC130", f"degrading '{f.name}' deactivates node {node.name}, which silences "
                                        f"{', '.join(silenced)}: not outputs of '{f.name}'", e.span,
                               notes=("an inactive lifecycle node publishes nothing on its lifecycle publishers",)))


def _check_functionality(sink: DiagnosticSink, c: ir.Component, f: ir.Functionality,
                         ports: dict[str, ir.Port], msgs: set[str]) -> None:
    for pname in f.ports:
        if pname not in ports:
            sink.add(error("RC107", f"functionality '{f.name}' names unknown port '{pname}' of '{c.name}'", f.span,
                           notes=(_suggest(pname, ports, f"'{c.name}' declares: " + (", ".join(ports) or "no ports")),)))
    outputs = {p for p in f.ports if p in ports and ports[p].kind == "output"}
    for kind in ("normal", "degraded"):
        mode: Optional[ir.Mode] = getattr(f, kind)
        if mode is None:
            sink.add(error("RC109", f"functionality '{f.name}' has no {kind} mode", f.span,
                           notes=("every functionality has a `normal { }` and a `degraded { }` mode",)))
            continue
        for a in mode.assumptions:
            _check_predicate(sink, a, msgs)
            if a.is_nothing:
                sink.add(error("RC126", "an assumption cannot be `nothing`", a.span))
        if kind == "degraded" and mode.assumptions:
            sink.add(error("RC111", f"the degraded mode of '{f.name}' assumes {mode.assumptions[0]}",
                           mode.assumptions[0].span, notes=("a degraded mode must work without any assumption",)))
        _unique(sink, "guarantee for", [ir.Port(g.port, "output", "", None, g.span) for g in mode.guarantees],
                f" in the {kind} mode of '{f.name}'")
        for g in mode.guarantees:
            _check_predicate(sink, g.predicate, msgs)
            if g.port not in outputs:
                sink.add(error("RC108", f"'{g.port}' is not an output of functionality '{f.name}'", g.span,
                               notes=(f"its outputs: {', '.join(sorted(outputs)) or 'none'}",)))
            elif g.predicate.message is not None and g.predicate.message != ports[g.port].message:
                sink.add(error("RC121", f"'{g.port}' carries {ports[g.port].message}, but the guarantee is "
                                        f"{g.predicate.message}", g.predicate.span,
                               related=(Related(ports[g.port].span, "port declared here"),)))
    if f.normal is not None and f.degraded is not None:
        for g in f.degraded.guarantees:
            normal = f.normal.guarantee(g.port)
            if not g.predicate.is_nothing and not ir.satisfies(normal, g.predicate):
                sink.add(error("RC112", f"the degraded guarantee {g.predicate} on '{g.port}' promises more than "
                                        f"the normal one ({normal})", g.span,
                               notes=("whatever a degraded guarantee satisfies, the normal one must satisfy too",)))


def _check_connector(sink: DiagnosticSink, conn: ir.Connector, msgs: set[str], comps: dict[str, ir.Component],
                     versions: set[str], attached: dict[tuple[str, str], ir.Connector]) -> None:
    _check_predicate(sink, conn.guarantee, msgs)
    if conn.guarantee.is_nothing:
        sink.add(error("RC126", f"{conn.kind} '{conn.name}' must guarantee a message type, not nothing",
                       conn.guarantee.span))
    if conn.kind == "service" and len(conn.publishers) > 1:
        sink.add(error("RC117", f"service '{conn.name}' has {len(conn.publishers)} servers; a service has one",
                       conn.publishers[1].span))
    elif conn.single and len(conn.publishers) > 1:
        sink.add(error("RC116", f"topic '{conn.name}' is `single` but has {len(conn.publishers)} publishers",
                       conn.publishers[1].span))
    for side, refs in (("output", conn.publishers), ("input", conn.subscribers)):
        for ref in refs:
            comp = comps.get(ref.component)
            if comp is None:
                sink.add(error("RC103", f"unknown component '{ref.component}'", ref.span,
                               notes=(_suggest(ref.component, comps, "declare it with `component NAME { }`"),)))
                continue
            if ref.component in versions:
                sink.add(error("RC122", f"'{ref.component}' is a replacement version of '{comp.replaces}' and is "
                                        "not deployed; it cannot be attached", ref.span))
                continue
            port = comp.port(ref.port)
            if port is None:
                names = [p.name for p in comp.ports]
                sink.add(error("RC104", f"component '{ref.component}' has no port '{ref.port}'", ref.span,
                               notes=(_suggest(ref.port, names, f"its ports: {', '.join(names) or 'none'}"),)))
                continue
            if port.kind != side:
                where = "left of '->' (publishers)" if side == "output" else "right of '->' (subscribers)"
                sink.add(error("RC105", f"'{ref}' is an {port.kind} but stands {where}", ref.span,
                               related=(Related(port.span, "port declared here"),)))
                continue
            key = (ref.component, ref.port)
            if key in attached:
                prev = attached[key]
                what = "twice to" if prev is conn else f"to '{prev.name}' and to"
                sink.add(error("RC123", f"'{ref}' is attached {what} '{conn.name}'; a port has one connector",
                               ref.span, related=(Related(prev.span, "already attached here"),)))
                continue
            attached[key] = conn
            if conn.kind == "service" and comp.node is not None:
                sink.add(error("RC132", f"'{ref}' is a port of node {comp.node.name}, which reconf does not build: "
                                        f"its adapter relays topics, not service '{conn.name}'", ref.span,
                               related=(Related(comp.node.span, "declared here"),)))
            if conn.guarantee.message is not None and port.message != conn.guarantee.message:
                sink.add(error("RC106", f"type mismatch: '{ref}' carries {port.message}, {conn.kind} "
                                        f"'{conn.name}' carries {conn.guarantee.message}", ref.span,
                               related=(Related(port.span, "port declared here"),
                                        Related(conn.guarantee.span, "connector type here"))))


def fail(code: str, message: str, span: Span) -> DiagnosticError:
    return DiagnosticError([error(code, message, span)])
