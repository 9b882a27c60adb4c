"""Hypothesis strategies for resolved architectures and their configurations, for tests that
compare engines (Python vs Alloy) or check actions: types, rates (Hz and periods), modes,
redundant publishers, environment guarantees, cycles, and names that are keywords elsewhere."""
from __future__ import annotations

from fractions import Fraction

from hypothesis import strategies as st

from checker.config import Configuration
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
