"""Hypothesis strategies for resolved architectures and their configurations, for tests that
compare engines (Python vs Alloy) or check actions: types, rates (Hz and periods), modes,
redundant publishers, environment guarantees, cycles, and names that are keywords elsewhere."""
from __future__ import annotations

from fractions import Fraction

from hypothesis import strategies as st

from checker.semantic_model.actions import Upgrade, effect, preconditions
from checker.semantic_model.config import Configuration
from reconf_dsl import ir

TYPES = ["M", "N", "sig"]
NAMES = ["a", "b", "run", "sig", "pred", "ünï", "lambda", "x_1", "open", "none"]
RATES = [None, ir.Rate(Fraction(1), "Hz"), ir.Rate(Fraction(10), "Hz"), ir.Rate(Fraction(100), "ms"),
         ir.Rate(Fraction(20), "Hz"), ir.Rate(Fraction(1, 2), "s")]


def pred(draw: st.DrawFn, message: str | None = None, nothing: bool = False) -> ir.Predicate:
    if nothing and draw(st.integers(0, 3)) == 0:
        return ir.NOTHING
    return ir.Predicate(message or draw(st.sampled_from(TYPES)), draw(st.sampled_from(RATES)))


@st.composite
def systems(draw: st.DrawFn, max_components: int = 5) -> ir.System:
    n = draw(st.integers(1, max_components))
    comps = []
    for i in range(n):
        cname = f"{draw(st.sampled_from(NAMES))}{i}"
        ports: list[ir.Port] = []
        for j in range(draw(st.integers(0, 2))):
            a = pred(draw)
            ports.append(ir.Port(f"in{j}", "input", a.message or "", a))
        for j in range(draw(st.integers(0, 2))):
            ports.append(ir.Port(f"out{j}", "output", draw(st.sampled_from(TYPES))))
        funcs = []
        for k in range(draw(st.integers(1, 2))):
            names = [p.name for p in ports]
            fports = tuple(draw(st.lists(st.sampled_from(names), unique=True))) if names else ()
            outs = [p for p in ports if p.kind == "output" and p.name in fports]
            normal_g = tuple(ir.Guarantee(p.name, pred(draw, p.message, nothing=True)) for p in outs)
            degraded_g = []
            for g in normal_g:
                # rule (iii): the degraded guarantee is nothing or something the normal one covers
                if g.predicate.is_nothing or draw(st.booleans()):
                    degraded_g.append(ir.Guarantee(g.port, ir.NOTHING))
                else:
                    degraded_g.append(ir.Guarantee(g.port, ir.Predicate(g.predicate.message, None)))
            asms = tuple(pred(draw) for _ in range(draw(st.integers(0, 2))))
            funcs.append(ir.Functionality(f"f{k}", fports, ir.Mode("normal", asms, normal_g),
                                          ir.Mode("degraded", (), tuple(degraded_g)), draw(st.integers(0, 3))))
        comps.append(ir.Component(cname, tuple(ports), tuple(funcs)))
    conns = []
    used: set[tuple[str, str]] = set()
    for t in range(draw(st.integers(0, 3))):
        g = pred(draw)
        pubs, subs = [], []
        for c in comps:
            for p in c.ports:
                if p.message == g.message and (c.name, p.name) not in used and draw(st.integers(0, 2)) > 0:
                    used.add((c.name, p.name))
                    (pubs if p.kind == "output" else subs).append(ir.PortRef(c.name, p.name))
        conns.append(ir.Connector(f"/t{t}/{draw(st.sampled_from(NAMES))}", "topic", g, False, tuple(pubs),
                                  tuple(subs)))
    env = tuple(ir.EnvGuarantee(f"e{i}", pred(draw)) for i in range(draw(st.integers(0, 2))))
    msgs = tuple(ir.MessageType(m, f"pkg/msg/{m}") for m in TYPES)
    return ir.System("gen", msgs, env, tuple(comps), (), tuple(conns))


@st.composite
def configured(draw: st.DrawFn, max_components: int = 5) -> tuple[ir.System, Configuration]:
    system = draw(systems(max_components))
    init = Configuration.initial(system)
    present = frozenset(c for c in sorted(init.components) if draw(st.integers(0, 5)) > 0)
    funcs = [(c.name, f.name) for c in system.components for f in c.functionalities if c.name in present]
    degraded = frozenset(f for f in funcs if draw(st.integers(0, 3)) == 0)
    roles = frozenset(r for r in sorted(init.roles) if r[1] in present and draw(st.integers(0, 5)) > 0)
    return system, Configuration(present, degraded, roles)


@st.composite
def dense(draw: st.DrawFn) -> tuple[ir.System, Configuration]:
    """A small, densely wired system in a valid configuration: one or two types, ports on
    several connectors, components reading their own outputs, functionalities sharing a
    port. This is where readings of the actions' preconditions part (tests/alloy/
    test_one_semantics.py)."""
    types = ["M"] if draw(st.integers(0, 2)) else ["M", "N"]
    rates = [None, None, ir.Rate(Fraction(1), "Hz"), ir.Rate(Fraction(10), "Hz")]

    def data() -> ir.Predicate:
        return ir.Predicate(draw(st.sampled_from(types)), draw(st.sampled_from(rates)))

    comps = []
    for i in range(draw(st.integers(1, 3))):
        ports = [ir.Port(f"i{j}", "input", a.message or "", a) for j, a in
                 enumerate(data() for _ in range(draw(st.integers(0, 2))))]
        ports += [ir.Port(f"o{j}", "output", draw(st.sampled_from(types))) for j in range(draw(st.integers(0, 2)))]
        funcs = []
        for k in range(draw(st.integers(1, 2))):
            every = draw(st.booleans())     # a functionality on all its component's ports often reads itself
            fports = tuple(p.name for p in ports if every or draw(st.booleans()))
            normal = [ir.Guarantee(p.name, ir.NOTHING if draw(st.integers(0, 4)) == 0 else
                                   ir.Predicate(p.message, draw(st.sampled_from(rates))))
                      for p in ports if p.kind == "output" and p.name in fports]
            degraded = [ir.Guarantee(g.port, ir.NOTHING if g.predicate.is_nothing or draw(st.booleans())
                                     else ir.Predicate(g.predicate.message, None)) for g in normal]
            asms = tuple(data() for _ in range(draw(st.integers(0, 2))))
            funcs.append(ir.Functionality(f"f{k}", fports, ir.Mode("normal", asms, tuple(normal)),
                                          ir.Mode("degraded", (), tuple(degraded)), draw(st.integers(0, 3))))
        comps.append(ir.Component(f"c{i}", tuple(ports), tuple(funcs)))
    conns = []
    for t in range(draw(st.integers(1, 3))):
        g = data()
        ends = [ir.PortRef(c.name, p.name) for c in comps for p in c.ports if p.message == g.message]
        conns.append(ir.Connector(f"/t{t}", "topic", g, False,
                                  tuple(r for r in ends if comps[int(r.component[1:])].port(r.port).kind == "output"),
                                  tuple(r for r in ends if comps[int(r.component[1:])].port(r.port).kind == "input")))
    env = (ir.EnvGuarantee("e0", data()),) if draw(st.integers(0, 3)) == 0 else ()
    system = ir.System("dense", tuple(ir.MessageType(m, f"pkg/msg/{m}") for m in types), env, tuple(comps), (),
                       tuple(conns))
    present = frozenset(c.name for c in comps if draw(st.integers(0, 4)) > 0)
    roles = frozenset((k.name, r.component, r.port) for k in conns for r in k.roles
                      if r.component in present and draw(st.integers(0, 3)) > 0)
    # every functionality degraded (valid), then upgraded while its assumptions hold: each
    # upgrade only adds satisfaction (rule iii), so the state stays valid
    config = Configuration(present, frozenset((c.name, f.name) for c in comps if c.name in present
                                              for f in c.functionalities), roles)
    grown = True
    while grown:
        grown = False
        for c, f in sorted(config.degraded):
            if not preconditions(system, config, Upgrade(c, f)) and draw(st.integers(0, 5)) > 0:
                config, grown = effect(system, config, Upgrade(c, f)), True
    return system, config
