"""Random architectures for planner tests, built as IR directly and seeded for reproducibility.

Modes follow rules (i)-(iii): the degraded mode assumes nothing and guarantees nothing or a
lower rate of the same type. Only systems whose deployed configuration is valid are kept.
"""
from __future__ import annotations

import random
from dataclasses import replace
from fractions import Fraction
from typing import Optional

from checker.semantic_model.actions import is_valid
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import (
    Component,
    Connector,
    EnvGuarantee,
    Functionality,
    Guarantee,
    MessageType,
    Mode,
    Port,
    PortRef,
    Predicate,
    Rate,
    System,
)

TYPES = ("A", "B")
RATES = (5, 10, 20)


def pred(msg: str, hz: Optional[int]) -> Predicate:
    return Predicate(msg, None if hz is None else Rate(Fraction(hz), "Hz"))


def component(rng: random.Random, name: str, max_ports: int = 2) -> Component:
    ins = [Port(f"i{k}", "input", t, pred(t, rng.choice(RATES + (None,))))
           for k, t in enumerate(rng.choice(TYPES) for _ in range(rng.randint(0, max_ports)))]
    outs = [Port(f"o{k}", "output", rng.choice(TYPES)) for k in range(rng.randint(0, max_ports))]
    if not ins and not outs:
        outs = [Port("o0", "output", rng.choice(TYPES))]
    funcs = []
    nf = rng.randint(1, 2)
    buckets: list[list[Port]] = [[] for _ in range(nf)]
    for p in ins + outs:
        buckets[rng.randrange(nf)].append(p)
    for k, ports in enumerate(buckets):
        if not ports:
            continue
        asms = tuple(p.assumption for p in ports if p.kind == "input" and p.assumption is not None
                     and rng.random() < 0.8)
        normal_g, degraded_g = [], []
        for p in ports:
            if p.kind != "output":
                continue
            hz = rng.choice(RATES)
            normal_g.append(Guarantee(p.name, pred(p.message, hz)))
            lower = [r for r in RATES if r < hz]
            if lower and rng.random() < 0.3:
                degraded_g.append(Guarantee(p.name, pred(p.message, rng.choice(lower))))
        funcs.append(Functionality(f"f{k}", tuple(p.name for p in ports), Mode("normal", asms, tuple(normal_g)),
                                   Mode("degraded", (), tuple(degraded_g)), criticality=rng.randint(1, 3)))
    return Component(name, tuple(ins + outs), tuple(funcs))


def _guarantee_of(c: Component, port: str) -> Predicate:
    for f in c.functionalities:
        if f.normal is not None and port in f.ports:
            return f.normal.guarantee(port)
    return Predicate(None)


def wire(rng: random.Random, comps: list[Component], n_topics: int, single_p: float = 0.3) -> list[Connector]:
    from reconf_dsl.ir import satisfies
    conns = []
    for k in range(n_topics):
        t = TYPES[k % len(TYPES)]
        g = pred(t, rng.choice(RATES[:2] + (None,)))
        pubs = [PortRef(c.name, p.name) for c in comps for p in c.outputs
                if p.message == t and satisfies(_guarantee_of(c, p.name), g) and rng.random() < 0.5]
        subs = [PortRef(c.name, p.name) for c in comps for p in c.inputs
                if p.assumption is not None and satisfies(g, p.assumption) and rng.random() < 0.7]
        single = rng.random() < single_p
        if single:
            pubs = pubs[:1]
        conns.append(Connector(f"/t{k}", "topic", g, single, tuple(pubs), tuple(subs)))
    # a port on one connector at most, as the DSL requires
    seen: set[tuple[str, str]] = set()
    out = []
    for c in conns:
        kept_pubs = tuple(r for r in c.publishers if (r.component, r.port) not in seen)
        seen |= {(r.component, r.port) for r in kept_pubs}
        kept_subs = tuple(r for r in c.subscribers if (r.component, r.port) not in seen)
        seen |= {(r.component, r.port) for r in kept_subs}
        out.append(replace(c, publishers=kept_pubs, subscribers=kept_subs))
    return out


def version_of(rng: random.Random, c: Component, name: str) -> Component:
    """Same ports, guarantees re-drawn at the same or a higher rate (so the target stays valid)."""
    funcs = []
    for f in c.functionalities:
        assert f.normal is not None
        gs = tuple(Guarantee(g.port, pred(g.predicate.message or "A", max(RATES) if rng.random() < 0.3 else
                                          int(g.predicate.hz or 10))) for g in f.normal.guarantees)
        funcs.append(replace(f, normal=replace(f.normal, guarantees=gs)))
    return replace(c, name=name, functionalities=tuple(funcs), replaces=c.name)


def random_system(seed: int, n: int = 4, n_topics: int = 3, single_p: float = 0.3, env_p: float = 0.2,
                  tries: int = 50) -> Optional[System]:
    """A valid random system with a version `<first component>_v2`, or None."""
    rng = random.Random(seed)
    for _ in range(tries):
        comps = [component(rng, f"c{k}") for k in range(n)]
        conns = wire(rng, comps, n_topics, single_p)
        env = (EnvGuarantee("sensor", pred("B", 20)),) if rng.random() < env_p else ()
        versions = (version_of(rng, comps[0], comps[0].name + "_v2"),)
        s = System("gen", tuple(MessageType(t, f"std_msgs/msg/{t}") for t in TYPES), env, tuple(comps), versions,
                   tuple(conns))
        if is_valid(s, Configuration.initial(s)) and any(r.component == "c0" for c in conns for r in c.roles):
            return s
    return None


def random_migration(seed: int, n: int = 4, n_topics: int = 3, tries: int = 50) -> Optional[tuple[System, System]]:
    """A valid old system and a valid new one: one component dropped, one added, c0 redefined,
    some attachments moved."""
    from reconf_dsl.ir import satisfies
    rng = random.Random(seed)
    for _ in range(tries):
        old = random_system(rng.randrange(1 << 30), n, n_topics)
        if old is None:
            continue
        comps = list(old.components)
        if len(comps) > 2:
            comps.pop(rng.randrange(1, len(comps)))
        comps[0] = replace(version_of(rng, comps[0], comps[0].name), replaces=None)
        comps.append(component(rng, "added"))
        conns: list[Connector] = []
        names = {c.name for c in comps}
        for conn in old.connectors:
            pubs = [r for r in conn.publishers if r.component in names]
            subs = [r for r in conn.subscribers if r.component in names and rng.random() < 0.8]
            for c in comps:
                for p in c.ports:
                    used = any((r.component, r.port) == (c.name, p.name) for k in conns + [conn] for r in k.roles)
                    if used or rng.random() > 0.4:
                        continue
                    if p.kind == "input" and p.assumption is not None and satisfies(conn.guarantee, p.assumption):
                        subs.append(PortRef(c.name, p.name))
                    elif (p.kind == "output" and satisfies(_guarantee_of(c, p.name), conn.guarantee)
                          and not (conn.single and pubs)):
                        pubs.append(PortRef(c.name, p.name))
            conns.append(replace(conn, publishers=tuple(pubs), subscribers=tuple(subs)))
        new = replace(old, components=tuple(comps), versions=(), connectors=tuple(conns))
        if is_valid(new, Configuration.initial(new)):
            return old, new
    return None
