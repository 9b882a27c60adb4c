"""The safety engine: satisfaction exactly as docs/design.md#the-semantic-model states it, on a networkx graph.

Graph nodes: ("out", comp, port), ("conn", name), ("in", comp, port), ("env", name).
Edges run the way data flows: output → connector → input. Functionalities read the graph:
an assumption holds when an associated input is satisfied and its assumption satisfies it,
or when an environment guarantee does. The property is local: no fixpoint, cycles are fine.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Optional

import networkx as nx

from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.gcpause import gc_paused
from reconf_dsl.ir import Component, Functionality, Mode, Predicate, System, format_number, satisfies
from reconf_dsl.span import Span

__all__ = ["satisfies", "shortfall", "Link", "AssumptionResult", "Evaluation", "evaluate", "build_graph",
           "current_mode", "witnesses"]


def shortfall(p: Predicate, q: Predicate) -> Optional[str]:
    """Why p does not satisfy q, in words; None when it does."""
    if satisfies(p, q):
        return None
    if p.message is None:
        return "it provides nothing"
    if p.message != q.message:
        return f"wrong type: {p.message}, not {q.message}"
    if p.hz is None:
        return f"no rate is promised and {q} needs one"
    return f"rate too low: {rate_text(p)} < {rate_text(q)}"


def rate_text(p: Predicate) -> str:
    """`10 Hz`, or `10 Hz (every 100 ms)` for a period."""
    assert p.rate is not None
    text = str(p).split(" @ ", 1)[1]
    if p.rate.unit in ("Hz", "kHz", "MHz"):
        return text
    return f"{format_number(p.rate.hz)} Hz (every {text})"


@dataclass(frozen=True)
class Link:
    """One step of an explanation: what was looked at, and whether it was fine."""

    kind: str          # functionality | assumption | input | connector | output | environment
    text: str
    span: Span
    ok: bool


@dataclass(frozen=True)
class AssumptionResult:
    component: str
    functionality: str
    index: int
    assumption: Predicate
    holds: bool
    chain: tuple[Link, ...] = ()


@dataclass
class Evaluation:
    system: System
    config: Configuration
    results: list[AssumptionResult] = field(default_factory=list)
    connectors: dict[str, bool] = field(default_factory=dict)
    inputs: dict[tuple[str, str], bool] = field(default_factory=dict)

    @property
    def valid(self) -> bool:
        return all(r.holds for r in self.results)

    @property
    def unsatisfied(self) -> list[AssumptionResult]:
        return [r for r in self.results if not r.holds]


def current_mode(f: Functionality, comp: str, config: Configuration) -> Mode:
    mode = f.degraded if (comp, f.name) in config.degraded else f.normal
    assert mode is not None, "resolved IR has both modes"
    return mode


def witnesses(system: System, config: Configuration, wide: int) -> dict[str, set[tuple[str, str]]]:
    """For each connector with more than `wide` attached outputs, one of them, (component,
    port), whose present functionality guarantees in its current mode what satisfies the
    connector's guarantee; connectors none satisfies are left out. A check's slice may
    show such a connector's witness alone (docs/soundness.md, "Slicing a large check")."""
    comps = _components(system, config)
    attached: dict[str, list[tuple[str, str]]] = {}
    for conn, c, p in config.roles:
        port = comps[c].port(p) if c in comps else None
        if port is not None and port.kind == "output":
            attached.setdefault(conn, []).append((c, p))
    out: dict[str, set[tuple[str, str]]] = {}
    for k in system.connectors:
        pubs = sorted(attached.get(k.name, ()))
        if len(pubs) <= wide:
            continue
        for c, p in pubs:
            if any(satisfies(gp, k.guarantee) for _, gp, _ in _guarantees(comps[c], p, config)):
                out[k.name] = {(c, p)}
                break
    return out


def _guarantees(c: Component, port: str, config: Configuration) -> list[tuple[Functionality, Predicate, bool]]:
    """What output `port` of `c` guarantees: for each functionality it belongs to, the
    guarantee of its current mode, and whether that mode is degraded. The output satisfies
    a guarantee when any of these does."""
    return [(f, current_mode(f, c.name, config).guarantee(port), (c.name, f.name) in config.degraded)
            for f in c.functionalities if port in f.ports]


def _components(system: System, config: Configuration) -> dict[str, Component]:
    catalogue = {c.name: c for c in system.components + system.versions}
    return {n: catalogue[n] for n in sorted(config.components) if n in catalogue}


def build_graph(system: System, config: Configuration) -> "nx.DiGraph[tuple[str, ...]]":
    """The data-flow graph of a configuration, with satisfaction computed on its nodes."""
    g: nx.DiGraph[tuple[str, ...]] = nx.DiGraph()
    comps = _components(system, config)
    conns = {c.name: c for c in system.connectors}
    for name, c in comps.items():
        for p in c.ports:
            if p.kind == "output":
                g.add_node(("out", name, p.name), port=p, component=c, guarantees=_guarantees(c, p.name, config))
            else:
                g.add_node(("in", name, p.name), port=p, component=c)
    for cname, conn in conns.items():
        g.add_node(("conn", cname), connector=conn)
    edges: list[tuple[tuple[str, ...], tuple[str, ...]]] = []
    for conn_name, comp, port in config.roles:
        if comp not in comps or conn_name not in conns:
            continue
        port_decl = comps[comp].port(port)
        if port_decl is None:
            continue
        if port_decl.kind == "output":
            edges.append((("out", comp, port), ("conn", conn_name)))
        else:
            edges.append((("conn", conn_name), ("in", comp, port)))
    g.add_edges_from(edges)
    for node, data in g.nodes(data=True):
        if node[0] == "conn":
            want = data["connector"].guarantee
            data["sat"] = any(any(satisfies(gp, want) for _, gp, _ in g.nodes[o]["guarantees"])
                              for o in g.predecessors(node))
    for node, data in g.nodes(data=True):
        if node[0] == "in":
            asm = data["port"].assumption
            data["sat"] = any(g.nodes[cn]["sat"] and satisfies(g.nodes[cn]["connector"].guarantee, asm)
                              for cn in g.predecessors(node))
    return g


def evaluate(system: System, config: Configuration, only: Optional[Iterable[FuncId]] = None,
             explain: bool = True) -> Evaluation:
    """Judge every assumption of every present functionality's current mode."""
    with gc_paused():
        return _evaluate(system, config, only, explain)


def _evaluate(system: System, config: Configuration, only: Optional[Iterable[FuncId]],
              explain: bool) -> Evaluation:
    g = build_graph(system, config)
    ev = Evaluation(system, config)
    ev.connectors = {n[1]: d["sat"] for n, d in g.nodes(data=True) if n[0] == "conn"}
    ev.inputs = {(n[1], n[2]): d["sat"] for n, d in g.nodes(data=True) if n[0] == "in"}
    wanted = set(only) if only is not None else None
    for name, comp in _components(system, config).items():
        for f in comp.functionalities:
            if wanted is not None and (name, f.name) not in wanted:
                continue
            mode = current_mode(f, name, config)
            for i, a in enumerate(mode.assumptions):
                holds = _holds(g, system, name, f, a)
                chain = () if holds or not explain else tuple(_explain(g, system, comp, f, mode, a))
                ev.results.append(AssumptionResult(name, f.name, i, a, holds, chain))
    return ev


def _holds(g: "nx.DiGraph[tuple[str, ...]]", system: System, comp: str, f: Functionality, a: Predicate) -> bool:
    for pname in f.ports:
        node = ("in", comp, pname)
        if node in g and g.nodes[node]["sat"] and satisfies(g.nodes[node]["port"].assumption, a):
            return True
    return any(satisfies(e.guarantee, a) for e in system.environment)


def support(system: System, config: Configuration, comp: Component, f: Functionality, a: Predicate) -> list[Link]:
    """Why an assumption that holds does: each satisfied input of `f` whose assumption
    satisfies `a`, with its satisfied connectors and the outputs that satisfy them, and each
    environment guarantee that satisfies `a` (empty when `a` does not hold)."""
    g = build_graph(system, config)
    links: list[Link] = []
    for pname in f.ports:
        node = ("in", comp.name, pname)
        if node not in g or not g.nodes[node]["sat"] or not satisfies(g.nodes[node]["port"].assumption, a):
            continue
        port = g.nodes[node]["port"]
        links.append(Link("input", f"input {comp.name}.{pname} assumes {port.assumption}, which satisfies it",
                          port.span, True))
        for cn in g.predecessors(node):
            conn = g.nodes[cn]["connector"]
            if not g.nodes[cn]["sat"]:
                continue
            links.append(Link("connector", f"{conn.kind} {conn.name} guarantees {conn.guarantee}", conn.span, True))
            for o in g.predecessors(cn):
                links += [Link("output", f"output {o[1]}.{o[2]}: {fo.name} guarantees {gp}", fo.span, True)
                          for fo, gp, _ in g.nodes[o]["guarantees"] if satisfies(gp, conn.guarantee)]
    links += [Link("environment", f"environment {e.name} guarantees {e.guarantee}", e.span, True)
              for e in system.environment if satisfies(e.guarantee, a)]
    return links


def _explain(g: "nx.DiGraph[tuple[str, ...]]", system: System, comp: Component, f: Functionality, mode: Mode,
             a: Predicate) -> list[Link]:
    links = [Link("functionality", f"{comp.name}.{f.name} ({mode.kind} mode)", f.span, False),
             Link("assumption", f"assumes {a}", a.span, False)]
    inputs = [p for p in comp.inputs if p.name in f.ports]
    if not inputs:
        links.append(Link("input", f"{f.name} reads no input that could provide {a}", f.span, False))
    for p in inputs:
        asm = p.assumption
        assert asm is not None
        why = shortfall(asm, a)
        if why:
            links.append(Link("input", f"input {comp.name}.{p.name} assumes {asm}: {why}", p.span, False))
            continue
        node = ("in", comp.name, p.name)
        conns = list(g.predecessors(node)) if node in g else []
        if not conns:
            links.append(Link("input", f"input {comp.name}.{p.name} is attached to nothing", p.span, False))
            continue
        links.append(Link("input", f"input {comp.name}.{p.name} assumes {asm}", p.span, False))
        for cn in conns:
            conn = g.nodes[cn]["connector"]
            why = shortfall(conn.guarantee, asm)
            if why:
                links.append(Link("connector", f"{conn.kind} {conn.name} guarantees {conn.guarantee}: {why}",
                                  conn.span, False))
                continue
            links.append(Link("connector", f"{conn.kind} {conn.name} guarantees {conn.guarantee}, but no "
                                           "attached output satisfies it", conn.span, False))
            outs = list(g.predecessors(cn))
            if not outs:
                links.append(Link("output", f"nothing publishes on {conn.name}", conn.span, False))
            for o in outs:
                links.extend(_explain_output(g, o, conn.guarantee))
    env_text = _explain_env(system, a)
    links.append(Link("environment", env_text, a.span, False))
    return links


def _explain_output(g: "nx.DiGraph[tuple[str, ...]]", node: tuple[str, ...], want: Predicate) -> list[Link]:
    data = g.nodes[node]
    who = f"{node[1]}.{node[2]}"
    if not data["guarantees"]:
        return [Link("output", f"output {who} belongs to no functionality", data["port"].span, False)]
    out: list[Link] = []
    for f, gp, degraded in data["guarantees"]:
        why = shortfall(gp, want) or "satisfies it"
        state = f"{f.name} is degraded and guarantees {gp}" if degraded else f"{f.name} guarantees {gp}"
        out.append(Link("output", f"output {who}: {state}: {why}", f.span, False))
    return out


def _explain_env(system: System, a: Predicate) -> str:
    same = [e for e in system.environment if e.guarantee.message == a.message]
    if not same:
        return f"no environment guarantee provides {a.message}"
    parts = [f"environment {e.name} gives {e.guarantee}: {shortfall(e.guarantee, a)}" for e in same]
    return "; ".join(parts)
