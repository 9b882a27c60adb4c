"""Pictures of a configuration: DOT in the rqt_graph look, and Mermaid.

Nodes are ellipses, topics boxes; a component with a degraded functionality is orange,
a removed one red, a created one green. No decisions here: states are given."""
from __future__ import annotations

import json
from dataclasses import dataclass, field

from .render import render


@dataclass(frozen=True)
class GraphNode:
    id: str
    label: str
    shape: str          # "ellipse" (component) | "box" (topic/service) | "note" (environment)
    status: str = "normal"   # normal | degraded | removed | created
    tooltip: str = ""


@dataclass(frozen=True)
class GraphEdge:
    source: str
    target: str
    label: str = ""
    status: str = "normal"


@dataclass
class Picture:
    title: str
    nodes: list[GraphNode] = field(default_factory=list)
    edges: list[GraphEdge] = field(default_factory=list)


def dot_id(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)


def mermaid_id(index: int) -> str:
    return f"n{index}"


def mermaid_label(text: str) -> str:
    return '"' + text.replace('"', "#quot;").replace("\n", "<br/>") + '"'


def to_dot(pic: Picture) -> str:
    return render("graph.dot.j2", pic=pic, q=dot_id)


def to_mermaid(pic: Picture) -> str:
    ids = {n.id: mermaid_id(i) for i, n in enumerate(pic.nodes)}
    return render("graph.mmd.j2", pic=pic, ids=ids, label=mermaid_label).rstrip("\n") + "\n"
