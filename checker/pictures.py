"""System + configuration → `codegen.graph.Picture` (what is degraded is decided here)."""
from __future__ import annotations

from typing import Optional

from codegen.graph import GraphEdge, GraphNode, Picture
from reconf_dsl.ir import System

from .config import Configuration


def picture(system: System, config: Optional[Configuration] = None, *, title: Optional[str] = None,
            removed: frozenset[str] = frozenset(), created: frozenset[str] = frozenset()) -> Picture:
    config = config or Configuration.initial(system)
    pic = Picture(title or system.name)
    catalogue = {c.name: c for c in system.components + system.versions}
    shown = sorted(config.components | removed)
    for name in shown:
        comp = catalogue[name]
        degraded = [f.name for f in comp.functionalities if (name, f.name) in config.degraded]
        status = "removed" if name in removed else "created" if name in created else \
            "degraded" if degraded else "normal"
        tip = ("degraded: " + ", ".join(degraded)) if degraded else ""
        pic.nodes.append(GraphNode("c:" + name, name, "ellipse", status, tip))
    for conn in system.connectors:
        label = f"{conn.name}\n{conn.guarantee}"
        pic.nodes.append(GraphNode("t:" + conn.name, label, "box"))
    for env in system.environment:
        pic.nodes.append(GraphNode("e:" + env.name, f"{env.name}\n{env.guarantee}", "note"))
    present = set(shown)
    for conn_name, comp_name, port in sorted(config.roles):
        owner = catalogue.get(comp_name)
        if owner is None or comp_name not in present:
            continue
        p = owner.port(port)
        if p is None:
            continue
        status = "removed" if comp_name in removed else "normal"
        if p.kind == "output":
            pic.edges.append(GraphEdge("c:" + comp_name, "t:" + conn_name, port, status))
        else:
            pic.edges.append(GraphEdge("t:" + conn_name, "c:" + comp_name, port, status))
    return pic
