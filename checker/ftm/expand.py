"""Expansion: a component with `ftm EXPR on h0, h1` → the generic computation graph of paper
000 (Fig. 2–6) as ordinary components and connectors of the semantic model.

For a server S whose replies leave on connector X (its first service, else its first topic):

- `S__proxy` takes S's place on X (clients keep their attachment). It relays what the
  outermost Protocol answers: it assumes X's guarantee from it and guarantees X; degraded, it
  still relays requests and replies, without rate.
- Per replica i (two for a duplex, else one), per layer (sec, dup, tr; outermost first):
  `S__r<i>_<layer>_protocol`, `_before`, `_after`, and for the innermost layer `_proceed`,
  which calls the replica's copy of the application (`S` itself on replica 0, `S__r1_app`
  on replica 1) through the service `/S/ftm/r<i>/srv`. Composition by nesting: the outer
  layer's Before feeds, and its After reads, the inner layer's Protocol instead of a Proceed.
- Duplex patterns: crash detectors `S__r0_cd` (heartbeat) and `S__r1_cd` (detect), and
  `S__recovery`, which switches the proxy binding to replica 1's outermost Protocol (its
  SEC layer's under SEC, so a takeover keeps the security layer); the After
  nodes exchange checkpoints / notifications, LFR and A&D Befores forward requests.
- SEC: client-side `S__sec_client_before` (cipher, sign) and `S__sec_client_after` (decipher,
  check) around the proxy, a server-side sec layer per replica, and the certification
  authority `S__ca`.

Each node has one functionality named after its Table II behaviour. A Protocol in its
degraded mode is *suspended*: it forwards nothing inwards but still accepts requests and
queues them, so it still guarantees the reply type, without rate, to the proxy, which then
cannot promise its clients the rate: while a protocol on its path is suspended, the proxy and
the clients that assume the rate are degraded (docs/ftm.md#expansion). Pipeline topics inside
a replica are `single` (one producer, as ROS remapping wires them), so substituting a node
suspends what depends on it rather than running two side by side. SEC's sealed requests
have their own type and topic (`FtmSealed`, `/S/ftm/cli2sec`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from fractions import Fraction
from typing import Optional

from reconf_dsl import ir
from reconf_dsl.diagnostics import DiagnosticError, error
from reconf_dsl.span import NO_SPAN, Span

from checker.ftm.library import Composition, compose, roles
from reconf_dsl.formatter import format_document

__all__ = ["FTM_MESSAGES", "expand", "expand_component", "protected_connector", "composition_of", "to_text",
           "protocols", "node_prefix", "ExpansionInfo"]

# The FTM nodes exchange JSON documents in std_msgs/msg/String (reconf_ros/ftm/wire.py); the
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
    def t(self) -> str:
        assert self.reply.message is not None
        return self.reply.message

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
    server = system.component(name)
    if server is None or server not in system.components:
        raise DiagnosticError([error("RC103", f"no deployed component '{name}'", system.span)])
    decl = decl if decl is not None else server.ftm
    if decl is None:
        raise DiagnosticError([error("RC408", f"'{name}' has no FTM to expand", server.span)])
    comp = composition_of(decl)
    conn, ref = protected_connector(system, server)
    span = decl.span if decl.span != NO_SPAN else server.span
    b = _Builder(server, comp, decl.hosts, conn.guarantee, span)
    t, g, s = b.t, conn.guarantee, server.name
    plain = ir.Predicate(t)
    p = node_prefix(s)
    info = ExpansionInfo(s, comp, conn.name)
    sec = any(m.layer == "sec" for m in comp.mechanisms)
    clients = [system.component(r.component) for r in conn.subscribers]
    client_host = next((c.host for c in clients if c is not None and c.host), None)

    # the proxy promises its clients the rate its protocols answer at; degraded, it still relays
    # requests and replies, with no rate
    info.proxy = b.add(p + "proxy", client_host, [("from_pro", g)], [("reply", t), ("to_pro", "FtmRequest")],
                       "relay", [g], [("reply", g), ("to_pro", REQ)], [("reply", plain), ("to_pro", REQ)])
    b.wire(_topic(s, "pro2pxy"), g, None, (info.proxy, "from_pro"))
    if sec:
        cb = b.add(p + "sec_client_before", client_host, [("from_proxy", REQ), ("cert", CERT)],
                   [("to_server", "FtmSealed")], "cipher_sign", [CERT], [("to_server", SEALED)],
                   [("to_server", ir.NOTHING)])
        ca_ = b.add(p + "sec_client_after", client_host, [("from_server", g)], [("to_proxy", t)],
                    "decipher_check", [g], [("to_proxy", g)], [("to_proxy", plain)])
        ca = b.add(p + "ca", None, [], [("cert", "FtmCert")], "certify", [], [("cert", CERT)],
                   [("cert", ir.NOTHING)])
        b.wire(_topic(s, "pxy2sec"), REQ, (info.proxy, "to_pro"), (cb, "from_proxy"))
        b.wire(_topic(s, "ca"), CERT, (ca, "cert"), (cb, "cert"))
        # sealed requests have a topic and a type of their own: a plain protocol, still linked
        # to the proxy's topic while a transition adds SEC, never reads one
        b.wire(_topic(s, "cli2sec"), SEALED, (cb, "to_server"), None)
        b.wire(_topic(s, "srv2cli"), g, None, (ca_, "from_server"))
        b.wire(_topic(s, "pro2pxy"), g, (ca_, "to_proxy"), None)
        entry_req, entry_rep = _topic(s, "cli2sec"), _topic(s, "srv2cli")
    else:
        b.wire(_topic(s, "pxy2pro"), REQ, (info.proxy, "to_pro"), None)
        entry_req, entry_rep = _topic(s, "pxy2pro"), _topic(s, "pro2pxy")

    for i in range(comp.replicas):
        host = b.host(i)
        app = server.name if i == 0 else f"{p}r{i}_app"
        plan = roles(comp, i)
        outer_req: Optional[str] = entry_req if i == 0 else None
        outer_rep: Optional[str] = entry_rep if i == 0 else None
        for k, (layer, role) in enumerate(plan):
            q = f"{p}r{i}_{layer}_"
            base = _topic(s, f"r{i}", layer)
            # every Protocol can be switched to primary (so a layer keeps its definition in any
            # composition); in a duplex, Recovery switches replica 1's outermost one
            ins: list[tuple[str, ir.Predicate]] = [("from_client", SEALED if layer == "sec" else REQ),
                                                   ("from_after", g), ("from_recovery", ALARM)]
            pro = b.add(q + "protocol", host, ins, [("reply", t), ("to_before", "FtmRequest")], "handle", [g],
                        [("reply", g), ("to_before", REQ)], [("reply", plain), ("to_before", ir.NOTHING)])
            info.protocols.append(pro)
            if outer_req is not None:
                b.wire(outer_req, SEALED if layer == "sec" else REQ, None, (pro, "from_client"), single=k > 0)
            if outer_rep is not None:
                b.wire(outer_rep, g, (pro, "reply"), None, single=k > 0)
            bins: list[tuple[str, ir.Predicate]] = [("from_protocol", REQ)]
            bouts = [("to_proceed", "FtmRequest")]
            bassume: list[ir.Predicate] = []
            bnormal: list[tuple[str, ir.Predicate]] = [("to_proceed", REQ)]
            if role.before == "forward_request":
                bouts.append(("to_peer", "FtmRequest"))
                bnormal.append(("to_peer", REQ))
            elif role.before == "handle_request":
                bins.append(("from_peer", REQ))
                bassume.append(REQ)
            elif role.before == "decipher_check":
                bins.append(("cert", CERT))
                bassume.append(CERT)
            bef = b.add(q + "before", host, bins, bouts, role.before, bassume, bnormal,
                        [(n, ir.NOTHING) for n, _ in bnormal])
            ains: list[tuple[str, ir.Predicate]] = [("from_proceed", g)]
            aouts = [("to_protocol", t)]
            aassume: list[ir.Predicate] = [g]
            anormal: list[tuple[str, ir.Predicate]] = [("to_protocol", g)]
            if role.after in ("checkpoint", "notify"):
                aouts.append(("to_peer", "FtmState"))
                anormal.append(("to_peer", STATE))
            elif role.after == "update_state":
                ains.append(("from_peer", STATE))
                aassume = [STATE]
            elif role.after == "handle_notification":
                ains.append(("from_peer", STATE))
                aassume.append(STATE)
            aft = b.add(q + "after", host, ains, aouts, role.after, aassume, anormal,
                        [(n, ir.NOTHING) for n, _ in anormal])
            b.wire(base + "/pro2bfr", REQ, (pro, "to_before"), (bef, "from_protocol"), single=True)
            b.wire(base + "/aft2pro", g, (aft, "to_protocol"), (pro, "from_after"), single=True)
            if layer == "dup":
                if role.before == "forward_request":
                    b.wire(_topic(s, "bfr2bfr"), REQ, (bef, "to_peer"), None)
                if role.before == "handle_request":
                    b.wire(_topic(s, "bfr2bfr"), REQ, None, (bef, "from_peer"))
                if "to_peer" in dict(aouts):
                    b.wire(_topic(s, "aft2aft"), STATE, (aft, "to_peer"), None)
                if "from_peer" in dict(ains):
                    b.wire(_topic(s, "aft2aft"), STATE, None, (aft, "from_peer"))
            if comp.duplex is not None and i == 1 and k == 0:
                b.wire(_topic(s, "rcy2pro"), ALARM, None, (pro, "from_recovery"))
            if layer == "sec":
                b.wire(_topic(s, "ca"), CERT, None, (bef, "cert"))
            outer_req, outer_rep = base + "/bfr2prd", base + "/prd2aft"
            b.wire(outer_req, REQ, (bef, "to_proceed"), None, single=True)
            b.wire(outer_rep, g, None, (aft, "from_proceed"), single=True)
        assert outer_req is not None and outer_rep is not None
        last = f"{p}r{i}_{plan[-1][0]}_"
        prd = b.add(last + "proceed", host, [("from_before", REQ), ("from_server", g)], [("result", t)],
                    "compute", [g], [("result", g)], [("result", ir.NOTHING)])
        b.wire(outer_req, REQ, None, (prd, "from_before"), single=True)
        b.wire(outer_rep, g, (prd, "result"), None, single=True)
        b.wire(_topic(s, f"r{i}", "srv"), g, (app, ref.port), (prd, "from_server"), kind="service")
        # a replica's copy runs the application's command under its own node name
        run = server.run if i == 0 or not server.run else f"{server.run} --ros-args -r __node:={app}"
        copy = dc_replace(server, name=app, host=host, run=run, ftm=None, faults=(), application=(), resources=())
        b.components.append(copy)
    if comp.duplex is not None:
        cd0 = b.add(p + "r0_cd", b.host(0), [], [("beat", "FtmHeartbeat")], "heartbeat", [], [("beat", BEAT)],
                    [("beat", ir.NOTHING)])
        cd1 = b.add(p + "r1_cd", b.host(1), [("beat", BEAT)], [("alarm", "FtmAlarm")], "detect", [BEAT],
                    [("alarm", ALARM)], [("alarm", ir.NOTHING)])
        info.detector = cd1
        rcy = b.add(p + "recovery", b.host(1), [("alarm", ALARM)], [("switch", "FtmAlarm")], "recover", [ALARM],
                    [("switch", ALARM)], [("switch", ir.NOTHING)])
        b.wire(_topic(s, "cd2cd"), BEAT, (cd0, "beat"), (cd1, "beat"))
        b.wire(_topic(s, "cd2rcy"), ALARM, (cd1, "alarm"), (rcy, "alarm"))
        b.wire(_topic(s, "rcy2pro"), ALARM, (rcy, "switch"), None)

    # The rest of the system: the server's place on X goes to the proxy; replica copies of the
    # application subscribe where the application did.
    new_conns: list[ir.Connector] = []
    for c in system.connectors:
        if c.name == conn.name:
            pubs = tuple(ir.PortRef(info.proxy, "reply", r.span) if r == ref else r for r in c.publishers)
            c = dc_replace(c, publishers=pubs)
        elif comp.replicas > 1 and any(r.component == s for r in c.subscribers):
            extra = tuple(ir.PortRef(f"{p}r{i}_app", r.port, r.span) for i in range(1, comp.replicas)
                          for r in c.subscribers if r.component == s)
            c = dc_replace(c, subscribers=c.subscribers + extra)
        new_conns.append(c)
    taken = {c.name for c in system.connectors}
    for c in b.connectors():
        if c.name in taken:
            raise DiagnosticError([error("RC409", f"expanding '{s}' needs connector '{c.name}', which is taken",
                                         span)])
        new_conns.append(c)
    names = {c.name for c in system.components + system.versions} - {s}
    clash = [c.name for c in b.components if c.name in names]
    if clash:
        raise DiagnosticError([error("RC409", f"expanding '{s}' needs component '{clash[0]}', which is taken",
                                     span)])
    comps: list[ir.Component] = []
    for other in system.components:
        if other.name == s:
            comps.extend(b.components)
        else:
            comps.append(other)
    have = {m.name for m in system.messages}
    msgs = system.messages + tuple(ir.MessageType(n, r, span) for n, r in FTM_MESSAGES if n not in have)
    info.components = [c.name for c in b.components]
    return dc_replace(system, messages=msgs, components=tuple(comps), connectors=tuple(new_conns)), info


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


def protocols(info: ExpansionInfo) -> list[str]:
    return list(info.protocols)


def to_text(system: ir.System) -> str:
    """The architecture as DSL text (it re-parses to an equal System)."""

    items: list[ir.Item] = [*system.messages, *system.environment, *system.hosts, *system.components,
                            *system.versions, *system.connectors]
    return format_document(ir.Document("<expanded>", system.name, tuple(items)))
