"""Expansion: a component with `ftm EXPR on h0, h1` → the generic computation graph of paper
000 (Fig. 2–6) as ordinary components and connectors of the semantic model.

For a server S whose replies leave on connector X (its first service, else its first topic):
`S__proxy` takes S's place on X; per replica and per layer (outermost first) a Protocol, Before
and After, and in the innermost layer a Proceed calling the replica's copy of the application;
for a duplex, crash detectors and Recovery; under SEC, the client side's Before and After and
the certification authority `S__ca`. Each node has one functionality named after its Table II
behaviour; a degraded Protocol is *suspended* (it queues requests). The names, topics and
modes, and why the proxy cannot promise its rate while a protocol is suspended:
docs/ftm.md#expansion.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from fractions import Fraction
from typing import Optional

from checker.ftm.library import Composition, RoleSpec, compose, roles
from reconf_dsl import ir
from reconf_dsl.diagnostics import DiagnosticError, error
from reconf_dsl.formatter import format_document
from reconf_dsl.span import NO_SPAN, Span

__all__ = ["FTM_MESSAGES", "expand", "expand_component", "protected_connector", "composition_of", "to_text",
           "node_prefix", "ExpansionInfo"]

# The FTM nodes exchange JSON documents in std_msgs/msg/String (reconf_ros/nodes/ftm/wire.py); the
# model tells the kinds apart by these names.
FTM_MESSAGES = (("FtmRequest", "std_msgs/msg/String"), ("FtmState", "std_msgs/msg/String"),
                ("FtmHeartbeat", "std_msgs/msg/String"), ("FtmAlarm", "std_msgs/msg/String"),
                ("FtmCert", "std_msgs/msg/String"), ("FtmSealed", "std_msgs/msg/String"))
HEARTBEAT_HZ = 10

REQ = ir.Predicate("FtmRequest")
STATE = ir.Predicate("FtmState")
ALARM = ir.Predicate("FtmAlarm")
CERT = ir.Predicate("FtmCert")
SEALED = ir.Predicate("FtmSealed")     # a request SEC's client side ciphered and signed
BEAT = ir.Predicate("FtmHeartbeat", ir.Rate(Fraction(HEARTBEAT_HZ), "Hz"))
LEASE = ir.Predicate("FtmHeartbeat")    # the backup's answer to each beat: the lease it grants the primary


def node_prefix(server: str) -> str:
    return f"{server}__"


def composition_of(decl: ir.FtmDecl) -> Composition:
    comp, problems = compose(decl.expr)
    if comp is None:
        raise DiagnosticError([error("RC401", f"ill-formed FTM '{decl.expr}': {p}", decl.expr.span)
                               for p in problems])
    return comp


class FtmRuleBroken(DiagnosticError):
    """An FTM rule the architecture breaks (RC407: nothing to protect): the architecture is
    unsafe, as `reconf check` says with exit 1, not malformed input."""


def protected_connector(system: ir.System, server: ir.Component) -> tuple[ir.Connector, ir.PortRef]:
    """The connector that carries the server's replies: its first service, else its first topic."""
    for kind in ("service", "topic"):
        for conn in system.connectors:
            if conn.kind != kind:
                continue
            for ref in conn.publishers:
                if ref.component == server.name:
                    return conn, ref
    span = server.ftm.span if server.ftm is not None else server.span
    raise FtmRuleBroken([error("RC407", f"'{server.name}' has an FTM but serves no service or topic to protect",
                                 span, notes=("attach it as server: `service /name: Type { "
                                              f"{server.name}.port -> client.port }}`",))])


@dataclass
class ExpansionInfo:
    """What one expansion produced, for transitions and tests."""

    server: str
    composition: Composition
    connector: str
    components: list[str] = field(default_factory=list)
    protocols: list[str] = field(default_factory=list)
    proxy: str = ""
    detector: str = ""      # a duplex's crash detector on the backup's side (it raises the alarm)


@dataclass
class _Builder:
    server: ir.Component
    comp: Composition
    hosts: tuple[str, ...]
    reply: ir.Predicate         # the protected connector's guarantee
    span: Span
    components: list[ir.Component] = field(default_factory=list)
    wires: dict[str, tuple[ir.Predicate, bool, str, list[ir.PortRef], list[ir.PortRef]]] = field(default_factory=dict)

    @property
    def reply_type(self) -> str:
        assert self.reply.message is not None
        return self.reply.message

    @property
    def plain(self) -> ir.Predicate:
        """The reply type with no rate: what a degraded node still guarantees."""
        return ir.Predicate(self.reply_type)

    def host(self, replica: int) -> Optional[str]:
        if not self.hosts:
            return self.server.host
        return self.hosts[min(replica, len(self.hosts) - 1)]

    def add(self, name: str, host: Optional[str], inputs: list[tuple[str, ir.Predicate]],
            outputs: list[tuple[str, str]], func: str, assumes: list[ir.Predicate],
            normal: list[tuple[str, ir.Predicate]], degraded: list[tuple[str, ir.Predicate]]) -> str:
        sp = self.span
        ports = tuple(ir.Port(n, "input", a.message or "", a, sp) for n, a in inputs) + \
            tuple(ir.Port(n, "output", m, None, sp) for n, m in outputs)
        f = ir.Functionality(func, tuple(p.name for p in ports),
                             ir.Mode("normal", tuple(assumes), tuple(ir.Guarantee(p, g, sp) for p, g in normal), sp),
                             ir.Mode("degraded", (), tuple(ir.Guarantee(p, g, sp) for p, g in degraded), sp),
                             1, sp)
        self.components.append(ir.Component(name, ports, (f,), None, host, span=sp))
        return name

    def wire(self, name: str, guarantee: ir.Predicate, pub: Optional[tuple[str, str]],
             sub: Optional[tuple[str, str]], single: bool = False, kind: str = "topic") -> None:
        g, s, k, pubs, subs = self.wires.setdefault(name, (guarantee, single, kind, [], []))
        if pub is not None:
            pubs.append(ir.PortRef(pub[0], pub[1], self.span))
        if sub is not None:
            subs.append(ir.PortRef(sub[0], sub[1], self.span))

    def connectors(self) -> list[ir.Connector]:
        return [ir.Connector(n, k, g, s, tuple(p), tuple(q), self.span)  # type: ignore[arg-type]
                for n, (g, s, k, p, q) in self.wires.items()]


def _topic(server: str, *parts: str) -> str:
    return "/" + "/".join((server, "ftm") + parts)


def expand_component(system: ir.System, name: str, decl: Optional[ir.FtmDecl] = None) -> tuple[ir.System, ExpansionInfo]:
    """`system` with component `name` expanded by `decl` (default: its own `ftm`)."""
    server, decl = _server_and_decl(system, name, decl)
    comp = composition_of(decl)
    conn, ref = protected_connector(system, server)
    span = decl.span if decl.span != NO_SPAN else server.span
    b = _Builder(server, comp, decl.hosts, conn.guarantee, span)
    info = ExpansionInfo(server.name, comp, conn.name)
    clients = [system.component(r.component) for r in conn.subscribers]
    client_host = next((c.host for c in clients if c is not None and c.host), None)
    entry_req, entry_rep = _add_client_side(b, info, client_host)
    for i in range(comp.replicas):
        _add_replica(b, info, i, ref.port, (entry_req, entry_rep) if i == 0 else None)
    if comp.duplex is not None:
        _add_crash_detection(b, info)
    connectors = _connectors_around(system, b, info, conn, ref)
    components = _components_in_place_of(system, b)
    have = {m.name for m in system.messages}
    msgs = system.messages + tuple(ir.MessageType(n, r, span) for n, r in FTM_MESSAGES if n not in have)
    info.components = [c.name for c in b.components]
    return dc_replace(system, messages=msgs, components=components, connectors=connectors), info


def _server_and_decl(system: ir.System, name: str, decl: Optional[ir.FtmDecl]) -> tuple[ir.Component, ir.FtmDecl]:
    """The deployed component `name` and the FTM to expand it by (`decl`, default its own)."""
    server = system.component(name)
    if server is None or server not in system.components:
        raise DiagnosticError([error("RC103", f"no deployed component '{name}'", system.span)])
    decl = decl if decl is not None else server.ftm
    if decl is None:
        raise DiagnosticError([error("RC408", f"'{name}' has no FTM to expand", server.span)])
    return server, decl


def _add_client_side(b: _Builder, info: ExpansionInfo, client_host: Optional[str]) -> tuple[str, str]:
    """The proxy, and under SEC the client side's Before and After and the certification
    authority; returns the topics replica 0's outermost Protocol reads requests from and
    answers on."""
    s, g, t = b.server.name, b.reply, b.reply_type
    p = node_prefix(s)
    # the proxy promises its clients the rate its protocols answer at; degraded, it still relays
    # requests and replies, with no rate
    info.proxy = b.add(p + "proxy", client_host, [("from_pro", g)], [("reply", t), ("to_pro", "FtmRequest")],
                       "relay", [g], [("reply", g), ("to_pro", REQ)], [("reply", b.plain), ("to_pro", REQ)])
    b.wire(_topic(s, "pro2pxy"), g, None, (info.proxy, "from_pro"))
    if not any(m.layer == "sec" for m in b.comp.mechanisms):
        b.wire(_topic(s, "pxy2pro"), REQ, (info.proxy, "to_pro"), None)
        return _topic(s, "pxy2pro"), _topic(s, "pro2pxy")
    sec_before = b.add(p + "sec_client_before", client_host, [("from_proxy", REQ), ("cert", CERT)],
                       [("to_server", "FtmSealed")], "cipher_sign", [CERT], [("to_server", SEALED)],
                       [("to_server", ir.NOTHING)])
    sec_after = b.add(p + "sec_client_after", client_host, [("from_server", g)], [("to_proxy", t)],
                      "decipher_check", [g], [("to_proxy", g)], [("to_proxy", b.plain)])
    authority = b.add(p + "ca", None, [], [("cert", "FtmCert")], "certify", [], [("cert", CERT)],
                      [("cert", ir.NOTHING)])
    b.wire(_topic(s, "pxy2sec"), REQ, (info.proxy, "to_pro"), (sec_before, "from_proxy"))
    b.wire(_topic(s, "ca"), CERT, (authority, "cert"), (sec_before, "cert"))
    # sealed requests have a topic and a type of their own: a plain protocol, still linked
    # to the proxy's topic while a transition adds SEC, never reads one
    b.wire(_topic(s, "cli2sec"), SEALED, (sec_before, "to_server"), None)
    b.wire(_topic(s, "srv2cli"), g, None, (sec_after, "from_server"))
    b.wire(_topic(s, "pro2pxy"), g, (sec_after, "to_proxy"), None)
    return _topic(s, "cli2sec"), _topic(s, "srv2cli")


def _add_replica(b: _Builder, info: ExpansionInfo, replica: int, server_port: str,
                 entry: Optional[tuple[str, str]]) -> None:
    """Replica `replica`'s layers, outermost first, its Proceed and its copy of the application;
    `entry` is the (request, reply) topics its outermost Protocol serves (replica 0 only)."""
    s, g = b.server.name, b.reply
    p = node_prefix(s)
    host = b.host(replica)
    app = s if replica == 0 else f"{p}r{replica}_app"
    plan = roles(b.comp, replica)
    outer: Optional[tuple[str, str]] = entry
    for depth, (layer, role) in enumerate(plan):
        outer = _add_layer(b, info, replica, depth, layer, role, outer)
    assert outer is not None
    outer_req, outer_rep = outer
    last = f"{p}r{replica}_{plan[-1][0]}_"
    proceed = b.add(last + "proceed", host, [("from_before", REQ), ("from_server", g)], [("result", b.reply_type)],
                    "compute", [g], [("result", g)], [("result", ir.NOTHING)])
    b.wire(outer_req, REQ, None, (proceed, "from_before"), single=True)
    b.wire(outer_rep, g, (proceed, "result"), None, single=True)
    b.wire(_topic(s, f"r{replica}", "srv"), g, (app, server_port), (proceed, "from_server"), kind="service")
    # a replica's copy runs the application's command under its own node name
    server = b.server
    run = server.run if replica == 0 or not server.run else f"{server.run} --ros-args -r __node:={app}"
    b.components.append(dc_replace(server, name=app, host=host, run=run, ftm=None, faults=(), application=(),
                                   resources=()))


@dataclass
class _Ports:
    """A Before's or After's ports, what it assumes and what it guarantees in normal mode."""

    inputs: list[tuple[str, ir.Predicate]]
    outputs: list[tuple[str, str]]
    assumes: list[ir.Predicate]
    normal: list[tuple[str, ir.Predicate]]

    def add(self, b: _Builder, name: str, host: Optional[str], func: str) -> str:
        """The node, publishing nothing when degraded."""
        return b.add(name, host, self.inputs, self.outputs, func, self.assumes, self.normal,
                     [(n, ir.NOTHING) for n, _ in self.normal])


def _before_ports(behaviour: str) -> _Ports:
    ports = _Ports([("from_protocol", REQ)], [("to_proceed", "FtmRequest")], [], [("to_proceed", REQ)])
    if behaviour == "forward_request":
        ports.outputs.append(("to_peer", "FtmRequest"))
        ports.normal.append(("to_peer", REQ))
    elif behaviour == "handle_request":
        ports.inputs.append(("from_peer", REQ))
        ports.assumes.append(REQ)
    elif behaviour == "decipher_check":
        ports.inputs.append(("cert", CERT))
        ports.assumes.append(CERT)
    return ports


def _after_ports(behaviour: str, reply: ir.Predicate, message: str) -> _Ports:
    ports = _Ports([("from_proceed", reply)], [("to_protocol", message)], [reply], [("to_protocol", reply)])
    if behaviour in ("checkpoint", "notify"):
        ports.outputs.append(("to_peer", "FtmState"))
        ports.normal.append(("to_peer", STATE))
    elif behaviour == "update_state":
        ports.inputs.append(("from_peer", STATE))
        ports.assumes = [STATE]
    elif behaviour == "handle_notification":
        ports.inputs.append(("from_peer", STATE))
        ports.assumes.append(STATE)
    return ports


def _add_layer(b: _Builder, info: ExpansionInfo, replica: int, depth: int, layer: str, role: RoleSpec,
               outer: Optional[tuple[str, str]]) -> tuple[str, str]:
    """One layer's Protocol, Before and After on a replica, fed by the `outer` (request, reply)
    topics if any; returns the topics the next layer in (or the Proceed) serves."""
    s, g = b.server.name, b.reply
    name = f"{node_prefix(s)}r{replica}_{layer}_"
    host = b.host(replica)
    base = _topic(s, f"r{replica}", layer)
    request = SEALED if layer == "sec" else REQ
    # every Protocol can be switched to primary (so a layer keeps its definition in any
    # composition); in a duplex, Recovery switches replica 1's outermost one
    protocol = b.add(name + "protocol", host, [("from_client", request), ("from_after", g), ("from_recovery", ALARM)],
                     [("reply", b.reply_type), ("to_before", "FtmRequest")], "handle", [g],
                     [("reply", g), ("to_before", REQ)], [("reply", b.plain), ("to_before", ir.NOTHING)])
    info.protocols.append(protocol)
    if outer is not None:
        b.wire(outer[0], request, None, (protocol, "from_client"), single=depth > 0)
        b.wire(outer[1], g, (protocol, "reply"), None, single=depth > 0)
    before_ports = _before_ports(role.before)
    before = before_ports.add(b, name + "before", host, role.before)
    after_ports = _after_ports(role.after, g, b.reply_type)
    after = after_ports.add(b, name + "after", host, role.after)
    b.wire(base + "/pro2bfr", REQ, (protocol, "to_before"), (before, "from_protocol"), single=True)
    b.wire(base + "/aft2pro", g, (after, "to_protocol"), (protocol, "from_after"), single=True)
    if layer == "dup":
        _wire_peers(b, before, role.before, after, after_ports)
    if b.comp.duplex is not None and replica == 1 and depth == 0:
        b.wire(_topic(s, "rcy2pro"), ALARM, None, (protocol, "from_recovery"))
    if layer == "sec":
        b.wire(_topic(s, "ca"), CERT, None, (before, "cert"))
    inner_req, inner_rep = base + "/bfr2prd", base + "/prd2aft"
    b.wire(inner_req, REQ, (before, "to_proceed"), None, single=True)
    b.wire(inner_rep, g, None, (after, "from_proceed"), single=True)
    return inner_req, inner_rep


def _wire_peers(b: _Builder, before: str, before_behaviour: str, after: str, after_ports: _Ports) -> None:
    """A duplex layer's links between the replicas: forwarded requests, checkpoints, notifications."""
    s = b.server.name
    if before_behaviour == "forward_request":
        b.wire(_topic(s, "bfr2bfr"), REQ, (before, "to_peer"), None)
    if before_behaviour == "handle_request":
        b.wire(_topic(s, "bfr2bfr"), REQ, None, (before, "from_peer"))
    if "to_peer" in dict(after_ports.outputs):
        b.wire(_topic(s, "aft2aft"), STATE, (after, "to_peer"), None)
    if "from_peer" in dict(after_ports.inputs):
        b.wire(_topic(s, "aft2aft"), STATE, None, (after, "from_peer"))


def _add_crash_detection(b: _Builder, info: ExpansionInfo) -> None:
    """A duplex's heartbeat on replica 0, its detector and Recovery on replica 1. The detector
    answers each beat with the lease it grants the primary (its degraded mode too, granting
    nothing); the heartbeat assumes nothing of it: a primary without a lease serves, one whose
    lease lapsed fences itself (docs/ftm.md#running)."""
    s, p = b.server.name, node_prefix(b.server.name)
    heartbeat = b.add(p + "r0_cd", b.host(0), [("lease", LEASE)], [("beat", "FtmHeartbeat")], "heartbeat", [],
                      [("beat", BEAT)], [("beat", ir.NOTHING)])
    detector = b.add(p + "r1_cd", b.host(1), [("beat", BEAT)], [("alarm", "FtmAlarm"), ("lease", "FtmHeartbeat")],
                     "detect", [BEAT], [("alarm", ALARM), ("lease", LEASE)], [("alarm", ir.NOTHING), ("lease", LEASE)])
    info.detector = detector
    recovery = b.add(p + "recovery", b.host(1), [("alarm", ALARM)], [("switch", "FtmAlarm")], "recover", [ALARM],
                     [("switch", ALARM)], [("switch", ir.NOTHING)])
    b.wire(_topic(s, "cd2cd"), BEAT, (heartbeat, "beat"), (detector, "beat"))
    b.wire(_topic(s, "lease"), LEASE, (detector, "lease"), (heartbeat, "lease"))
    b.wire(_topic(s, "cd2rcy"), ALARM, (detector, "alarm"), (recovery, "alarm"))
    b.wire(_topic(s, "rcy2pro"), ALARM, (recovery, "switch"), None)


def _connectors_around(system: ir.System, b: _Builder, info: ExpansionInfo, conn: ir.Connector,
                       ref: ir.PortRef) -> tuple[ir.Connector, ...]:
    """The system's connectors with the server's place on the protected one given to the proxy
    and replica copies of the application subscribed where the application was, then the
    expansion's own."""
    s, replicas = b.server.name, b.comp.replicas
    out: list[ir.Connector] = []
    for c in system.connectors:
        if c.name == conn.name:
            pubs = tuple(ir.PortRef(info.proxy, "reply", r.span) if r == ref else r for r in c.publishers)
            c = dc_replace(c, publishers=pubs)
        elif replicas > 1 and any(r.component == s for r in c.subscribers):
            extra = tuple(ir.PortRef(f"{node_prefix(s)}r{i}_app", r.port, r.span) for i in range(1, replicas)
                          for r in c.subscribers if r.component == s)
            c = dc_replace(c, subscribers=c.subscribers + extra)
        out.append(c)
    taken = {c.name for c in system.connectors}
    for c in b.connectors():
        if c.name in taken:
            raise DiagnosticError([error("RC409", f"expanding '{s}' needs connector '{c.name}', which is taken",
                                         b.span)])
        out.append(c)
    return tuple(out)


def _components_in_place_of(system: ir.System, b: _Builder) -> tuple[ir.Component, ...]:
    """The system's components with the server replaced by the expansion's."""
    s = b.server.name
    names = {c.name for c in system.components + system.versions} - {s}
    clash = [c.name for c in b.components if c.name in names]
    if clash:
        raise DiagnosticError([error("RC409", f"expanding '{s}' needs component '{clash[0]}', which is taken",
                                     b.span)])
    comps: list[ir.Component] = []
    for other in system.components:
        if other.name == s:
            comps.extend(b.components)
        else:
            comps.append(other)
    return tuple(comps)


def expand(system: ir.System, overrides: Optional[dict[str, Optional[ir.FtmDecl]]] = None
           ) -> tuple[ir.System, list[ExpansionInfo]]:
    """Expand every deployed component's FTM (or the one `overrides` gives; None = no FTM)."""
    overrides = overrides or {}
    todo = [(c.name, overrides.get(c.name, c.ftm)) for c in system.components]
    infos = []
    out = system
    for name, decl in todo:
        if decl is None:
            if name in overrides:
                comp = out.component(name)
                assert comp is not None
                out = dc_replace(out, components=tuple(dc_replace(c, ftm=None) if c.name == name else c
                                                       for c in out.components))
            continue
        out, info = expand_component(out, name, decl)
        infos.append(info)
    return out, infos


def to_text(system: ir.System) -> str:
    """The architecture as DSL text (it re-parses to an equal System)."""

    items: list[ir.Item] = [*system.messages, *system.environment, *system.hosts, *system.components,
                            *system.versions, *system.connectors]
    return format_document(ir.Document("<expanded>", system.name, tuple(items)))
