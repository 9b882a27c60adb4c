"""ROS 2 plan scripts: one self-contained Python file per plan (docs/executor.md).

The caller decides everything and hands over a plan document, a JSON-able dict:

    {"format_version": 2, "system": name, "fingerprint": "sha256:...", "evidence": {...},
     "plan": plan.to_dict(), "model": model_data(system)}

The plan holds its first state in full (`start`) and, per step, what the step changed
(`changes`: `add` and `drop`, each with `components`, `degraded` and `roles`), so a document
grows with the plan's length; `state_at` gives a state back (the executor's `PlanStates`, all
of them). Version 1 held every state in full (`states`): those are still read, but only version
2 is written.

`render_plan_script` embeds it as a JSON literal in `templates/plan_ros2.py.j2`, together with
the text of the plan executor, the modules of `reconf_ros/executor/` joined into one
(`executor_source`; read as package data: the executor imports only the standard library until it
applies a plan, so the script is self-contained).
The script replays the plan offline (`--dry-run`, no ROS needed) with the executor's copy of
the satisfaction rules of docs/design.md#the-semantic-model (held to the checker's by tests), or
drives the running system through lifecycle services, the parameter-based control interface of
docs/control-interface.md and the nodes' statuses (docs/executor.md).

`model_data` is a plain data conversion of the IR; rates become exact fractions in hertz,
written as strings ("10", "1/2").
"""
from __future__ import annotations

import ast
import json
from importlib import resources
from typing import Any, Optional

from reconf_dsl.ir import (
    Component,
    Connector,
    Effect,
    EnvGuarantee,
    Functionality,
    Guarantee,
    Host,
    MessageType,
    Mode,
    NodeMode,
    NodeTopic,
    Port,
    PortRef,
    Predicate,
    Rate,
    RosNode,
    System,
)
from reconf_ros.executor import EMBEDDED
from reconf_ros.executor.plan_states import PlanStates

__all__ = ["FORMAT_VERSION", "model_data", "node_back", "node_data", "render_plan_script", "system_at", "system_from_model_data",
           "state_at"]

FORMAT_VERSION = 2
_KEYS = ("format_version", "system", "fingerprint", "evidence", "plan", "model")


def _predicate(p: Optional[Predicate]) -> Optional[dict[str, Any]]:
    if p is None:
        return None
    hz = p.hz
    return {"message": p.message, "hz": None if hz is None else str(hz), "text": str(p)}


def _mode(m: Optional[Mode]) -> Optional[dict[str, Any]]:
    if m is None:
        return None
    return {"assumptions": [_predicate(a) for a in m.assumptions],
            "guarantees": [{"port": g.port, "predicate": _predicate(g.predicate)} for g in m.guarantees]}


def _functionality(f: Functionality) -> dict[str, Any]:
    return {"name": f.name, "ports": list(f.ports), "criticality": f.criticality,
            "normal": _mode(f.normal), "degraded": _mode(f.degraded)}


def _component(c: Component, deployed: bool) -> dict[str, Any]:
    out = {"name": c.name, "deployed": deployed, "replaces": c.replaces, "run": c.run, "host": c.host,
           "ports": [{"name": p.name, "kind": p.kind, "message": p.message, "assumption": _predicate(p.assumption)}
                     for p in c.ports],
           "functionalities": [_functionality(f) for f in c.functionalities]}
    if c.node is not None:          # not a reconf node: how its adapter drives it (docs/adapter.md)
        out["node"] = node_data(c.node)
    return out


def node_data(n: RosNode) -> dict[str, Any]:
    """A `node` block as plain data (the executor starts such a component through its adapter)."""
    return {"name": n.name, "lifecycle": n.lifecycle, "topics": {t.port: t.ros_name for t in n.topics},
            "modes": [{"functionality": m.functionality, "mode": m.mode,
                       "effects": [{"kind": e.kind, "param": e.param, "value": e.value} for e in m.effects]}
                      for m in n.modes]}


def node_back(d: Optional[dict[str, Any]]) -> Optional[RosNode]:
    """The inverse of `node_data`."""
    if d is None:
        return None
    return RosNode(d["name"], d["lifecycle"], tuple(NodeTopic(p, r) for p, r in d["topics"].items()),
                   tuple(NodeMode(m["functionality"], m["mode"],
                                  tuple(Effect(e["kind"], e["param"], e["value"]) for e in m["effects"]))
                         for m in d["modes"]))


def _connector(c: Connector) -> dict[str, Any]:
    return {"name": c.name, "kind": c.kind, "guarantee": _predicate(c.guarantee), "single": c.single,
            "single_publisher": c.single_publisher,
            "publishers": [[r.component, r.port] for r in c.publishers],
            "subscribers": [[r.component, r.port] for r in c.subscribers]}


def model_data(system: System) -> dict[str, Any]:
    """The architecture as plain data: what a plan script needs to judge a configuration."""
    return {"name": system.name,
            "messages": [{"name": m.name, "ros_type": m.ros_type} for m in system.messages],
            "environment": [{"name": e.name, "guarantee": _predicate(e.guarantee)} for e in system.environment],
            "components": [_component(c, True) for c in system.components]
            + [_component(c, False) for c in system.versions],
            "connectors": [_connector(c) for c in system.connectors],
            "hosts": [h.name for h in system.hosts]}


def _dump(value: Any, depth: int = 0, expand: int = 3) -> str:
    """JSON, sorted, ASCII: containers one item a line down to `expand` levels, compact below."""
    compact = json.dumps(value, sort_keys=True, ensure_ascii=True, separators=(", ", ": "))
    if depth >= expand or not isinstance(value, (dict, list)) or not value:
        return compact
    pad, inner = " " * depth, " " * (depth + 1)
    if isinstance(value, dict):
        # the model gets two more levels: a component's fields, and its functionalities, a line each
        items = [f"{inner}{json.dumps(k, ensure_ascii=True)}: "
                 f"{_dump(v, depth + 1, expand + 2 if depth == 0 and k == 'model' else expand)}"
                 for k, v in sorted(value.items())]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    items = [inner + _dump(v, depth + 1, expand) for v in value]
    return "[\n" + ",\n".join(items) + "\n" + pad + "]"


def _top_imports(tree: ast.Module) -> list[ast.stmt]:
    """A module's leading docstring and import statements, the part a joined text replaces."""
    head: list[ast.stmt] = []
    for stmt in tree.body:
        docstring = isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant) and not head
        if not (docstring or isinstance(stmt, (ast.Import, ast.ImportFrom))):
            break
        head.append(stmt)
    return head


def executor_source() -> str:
    """The plan executor's modules (`reconf_ros.executor`, in the order of its `EMBEDDED`) joined
    into one text: their standard-library imports merged at the top, the imports among them and
    their docstrings dropped, then each module's body as it is. The modules define every name
    once across the package (tests/test_ros_script.py holds the joined text to them)."""
    names: dict[str, set[str]] = {}
    plain: set[str] = set()
    bodies = []
    for module in EMBEDDED:
        text = resources.files("reconf_ros.executor").joinpath(f"{module}.py").read_text(encoding="utf-8")
        head = _top_imports(ast.parse(text))
        for stmt in head:
            if isinstance(stmt, ast.Import):
                plain.update(a.name for a in stmt.names)
            elif isinstance(stmt, ast.ImportFrom) and not stmt.level and stmt.module != "__future__":
                names.setdefault(str(stmt.module), set()).update(a.name for a in stmt.names)
        start = (head[-1].end_lineno or 0) if head else 0
        body = "".join(text.splitlines(keepends=True)[start:]).strip("\n")
        bodies.append(f"# --- reconf_ros/executor/{module}.py ---\n\n{body}")
    imports = ["from __future__ import annotations", ""] + [f"import {m}" for m in sorted(plain)] + \
        [f"from {m} import {', '.join(sorted(n))}" for m, n in sorted(names.items())]
    return "\n".join(imports) + "\n\n\n" + "\n\n\n".join(bodies)


def render_plan_script(plan_doc: dict[str, Any]) -> str:
    """The ROS 2 Python script for `plan_doc`; deterministic (same document, same text)."""
    missing = [k for k in _KEYS if k not in plan_doc]
    if missing:
        raise ValueError(f"plan document lacks {', '.join(missing)}")
    if plan_doc["format_version"] != FORMAT_VERSION:
        raise ValueError(f"plan document format {plan_doc['format_version']!r} is not {FORMAT_VERSION}")
    text = _dump(plan_doc)
    # A raw triple-quoted string holds any JSON text: JSON escapes every quote inside strings,
    # so three quotes in a row never occur, and the text ends with "}", never a backslash.
    assert '"""' not in text
    from .render import render  # jinja2, only when a script is written
    plan = plan_doc["plan"]
    return render("plan_ros2.py.j2", doc_json=text, executor=executor_source(), system=str(plan_doc["system"]),
                  fingerprint=str(plan_doc["fingerprint"]), strategy=str(plan.get("strategy", "")),
                  steps=len(plan.get("steps", [])))


def state_at(plan: dict[str, Any], index: int = -1) -> dict[str, list[Any]]:
    """State `index` of a document's `plan` (negative counts from the end), each part sorted; read
    by the executor's own reader (`reconf_ros.executor.plan_states.PlanStates`, standard library only)."""
    return PlanStates(plan)[index].to_doc()


def system_at(plan_doc: dict[str, Any], index: int = -1) -> System:
    """The architecture a plan document has reached at state `index` (its target by default): the
    components present then, a new version under its name in the new architecture (`X@new` is
    `X`), and each connector with that state's roles. A node a plan starts without a run line
    is built from it (`reconf-node --plan`), so it sees the architecture it is part of."""
    model, plan = plan_doc["model"], plan_doc["plan"]
    renames: dict[str, str] = plan.get("renames", {})
    state = state_at(plan, index)
    present = set(state["components"])
    taken = {renames[n] for n in renames if n in present}       # old names a present new version takes
    comps = [dict(c, name=renames.get(c["name"], c["name"]), deployed=True,
                  replaces=None if c["name"] in renames else c.get("replaces"))
             for c in model["components"] if c["name"] in present and not (c["name"] in taken and c["name"] not in renames)]
    kinds = {(c["name"], p["name"]): p["kind"] for c in model["components"] for p in c["ports"]}
    names = {k["name"] for k in model["connectors"]}
    conns = []
    for k in model["connectors"]:
        if k["name"] not in renames and any(renames.get(n) == k["name"] for n in names):
            continue                                            # replaced by its new version
        roles = [(c, p) for n, c, p in state["roles"] if n == k["name"]]
        conns.append(dict(k, name=renames.get(k["name"], k["name"]),
                          publishers=[[renames.get(c, c), p] for c, p in roles if kinds.get((c, p)) == "output"],
                          subscribers=[[renames.get(c, c), p] for c, p in roles if kinds.get((c, p)) == "input"]))
    return system_from_model_data(dict(model, components=comps, connectors=conns))


def _predicate_back(p: Optional[dict[str, Any]]) -> Optional[Predicate]:
    from fractions import Fraction
    if p is None:
        return None
    if p["message"] is None:
        return Predicate(None)
    return Predicate(p["message"], None if p["hz"] is None else Rate(Fraction(p["hz"]), "Hz"))


def system_from_model_data(model: dict[str, Any]) -> System:
    """The inverse of `model_data` (spans and layout aside): a plan document's model as IR, so a
    run report can be planned from (`reconf recover`)."""

    def mode(m: Optional[dict[str, Any]], kind: Any) -> Optional[Mode]:
        if m is None:
            return None
        return Mode(kind, tuple(_predicate_back(a) for a in m["assumptions"]),  # type: ignore[misc]
                    tuple(Guarantee(g["port"], _predicate_back(g["predicate"])) for g in m["guarantees"]))  # type: ignore[arg-type]

    def component(c: dict[str, Any]) -> Component:
        ports = tuple(Port(p["name"], p["kind"], p["message"], _predicate_back(p["assumption"])) for p in c["ports"])
        funcs = tuple(Functionality(f["name"], tuple(f["ports"]), mode(f["normal"], "normal"),
                                    mode(f["degraded"], "degraded"), f["criticality"]) for f in c["functionalities"])
        return Component(c["name"], ports, funcs, c.get("run"), c.get("host"), c.get("replaces"),
                         node=node_back(c.get("node")))

    conns = tuple(Connector(k["name"], k["kind"], _predicate_back(k["guarantee"]), k["single"],  # type: ignore[arg-type]
                            tuple(PortRef(c, p) for c, p in k["publishers"]),
                            tuple(PortRef(c, p) for c, p in k["subscribers"])) for k in model["connectors"])
    return System(model["name"], tuple(MessageType(m["name"], m["ros_type"]) for m in model["messages"]),
                  tuple(EnvGuarantee(e["name"], _predicate_back(e["guarantee"])) for e in model["environment"]),  # type: ignore[arg-type]
                  tuple(component(c) for c in model["components"] if c["deployed"]),
                  tuple(component(c) for c in model["components"] if not c["deployed"]), conns,
                  tuple(Host(h) for h in model.get("hosts", [])))
