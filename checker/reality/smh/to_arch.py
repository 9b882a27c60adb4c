"""An SMH model as the starting point of an architecture (docs/modes.md#import).

One component per SMH node. A node whose modes set `reconf.mode.<f>` parameters (as `reconf modes
export` writes them) gets one functionality per such f; any other node one functionality named
after it, its modes' parameter values kept as comments. SMH says nothing of ports, message
types, rates or topics: each is a `// placeholder` comment and an RC623 warning. What SMH says
that an architecture cannot (system modes, rules, lifecycle states other than active, parameter
values) is kept as comments, with an RC624 warning where it is dropped."""
from __future__ import annotations

import os
import re

from checker.reality.smh import DEGRADED_VALUE, PARAM
from checker.reality.smh.read import Model, Part, SystemMode
from checker.reality.unique_names import unique
from reconf_dsl.diagnostics import Diagnostic, warning

__all__ = ["to_arch"]

_NAME = re.compile(r"[^\W\d]\w*")


def to_arch(model: Model) -> tuple[str, list[Diagnostic]]:
    """The .arch text and the warnings: what is a placeholder, what is not carried over."""
    warns = list(model.warnings)
    nodes = [p for p in model.parts if p.kind == "node"]
    systems = [p for p in model.parts if p.kind == "system"]
    taken: set[str] = set()
    idents = {p.name: _ident(p.name, taken) for p in nodes}
    for p in nodes:
        if idents[p.name] != p.name:
            warns.append(warning("RC624", f"node {p.name} is the component {idents[p.name]}: a component's name "
                                          "is a name of the DSL and its node's name", p.span,
                                 notes=(_rename_note(p.name, idents[p.name]),)))
    inner = {pm.part for s in systems for m in s.system_modes for pm in m.parts}
    roots = [s for s in systems if s.name not in inner]
    name = _ident(roots[0].name if len(roots) == 1 else _stem(model.file), set())
    lines = [f"// Made from the SMH model file {model.file} by `reconf modes import`: a starting point.",
             "// SMH says nothing of ports, message types, rates or topics: every `// placeholder`",
             "// below is one to fill in (docs/modes.md#import).",
             f"system {name}", "",
             "// placeholder: message types (message NAME = package/msg/Type)"]
    for s in systems:
        lines += [""] + _system_comment(s, model)
        warns += _system_warnings(s, model)
    for p in nodes:
        body, more = _component(p, idents[p.name])
        lines += [""] + body
        warns += more
    lines += ["", "// placeholder: topics and services, which SMH files do not name, e.g.",
              "//   topic /NAME: TYPE @ RATE { producer.out -> consumer.in }"]
    where = model.parts[0].span
    warns.append(warning("RC623", "SMH says nothing of topics or services: the architecture connects nothing; "
                                  "see its placeholder", where))
    return "\n".join(lines) + "\n", sorted(warns, key=lambda d: (d.span.line, d.span.col))


def _rename_note(node: str, ident: str) -> str:
    ns, _, last = node.rpartition("/")
    alt = f", or name the component {last} and run plans with --namespace {ns}" if ns and _NAME.fullmatch(last) else ""
    return (f"reconf addresses a component as the node of its name, /{ident} (docs/control-interface.md): "
            f"start it with `--ros-args -r __node:={ident}`{alt}")


def _component(p: Part, ident: str) -> tuple[list[str], list[Diagnostic]]:
    """The component of node `p`, and its warnings."""
    funcs = _reconf_functionalities(p)
    lines = [f"// SMH node {p.name} ({p.span}), its modes:"]
    for m in p.node_modes:
        shown = ", ".join(f"{x.name}: {x.value}" for x in m.params) or "sets nothing"
        lines.append(f"//   {m.name}: {shown}")
    warns = [warning("RC623", f"SMH says nothing of {p.name}'s ports, message types or rates: see the "
                              f"placeholders of component {ident}", p.span)]
    if not funcs:
        warns.append(warning("RC624", f"the modes of {p.name} set parameters, which an architecture does not "
                                      f"model: one functionality stands for the node, its modes are comments",
                             p.span))
    taken: set[str] = set()
    names = [_ident(f, taken) for f in funcs] or [ident]
    lines += [f"component {ident} {{",
              "  // placeholder: ports, which SMH files do not name (input NAME: TYPE @ RATE, output NAME: TYPE),",
              "  // then listed in the functionality that uses them"]
    for f in names:
        lines += [f"  functionality {f} () {{",
                  "    normal { }  // placeholder: what the normal mode assumes and guarantees (types, rates)",
                  "    degraded { }",
                  "  }"]
    lines.append("}")
    return lines, warns


def _reconf_functionalities(p: Part) -> list[str]:
    """The f of every `reconf.mode.f` parameter of the node's modes, in order of appearance."""
    out: list[str] = []
    for m in p.node_modes:
        for x in m.params:
            f = x.name[len(PARAM):]
            if x.name.startswith(PARAM) and f and f not in out:
                out.append(f)
    return out


def _system_comment(s: Part, model: Model) -> list[str]:
    parts = list(dict.fromkeys(pm.part for m in s.system_modes for pm in m.parts))
    lines = [f"// SMH system {s.name} ({s.span}), parts {', '.join(parts)}; its modes:"]
    for m in s.system_modes:
        shown = ", ".join(f"{pm.part} {pm.state}" + (f".{pm.mode}" if pm.mode else "") for pm in m.parts)
        degraded = _degraded(m, model)
        lines.append(f"//   {m.name}: {shown}" + (f" (degraded: {', '.join(degraded)})" if degraded else ""))
    if s.rules:
        lines.append(f"//   rules (not carried over): {', '.join(s.rules)}")
    return lines


def _degraded(m: SystemMode, model: Model) -> list[str]:
    """The functionalities the mode degrades, as `component.f`, where its parts' modes say so."""
    nodes = {p.name: p for p in model.parts if p.kind == "node"}
    out = []
    for pm in m.parts:
        node = nodes.get(pm.part)
        mode = next((x for x in node.node_modes if x.name == pm.mode), None) if node and pm.mode else None
        out += [f"{pm.part}.{x.name[len(PARAM):]}" for x in (mode.params if mode else ())
                if x.name.startswith(PARAM) and x.value == DEGRADED_VALUE]
    return out


def _system_warnings(s: Part, model: Model) -> list[Diagnostic]:
    known = {p.name: p for p in model.parts}
    out = [warning("RC624", f"system {s.name}: its modes are comments; an architecture has one configuration, "
                            "and `reconf plan` moves between them", s.span)]
    if s.rules:
        out.append(warning("RC624", f"system {s.name}: rules are not carried over ({', '.join(s.rules)})", s.span))
    for m in s.system_modes:
        for pm in m.parts:
            part = known.get(pm.part)
            if part is None:
                out.append(warning("RC624", f"mode {m.name} of {s.name} names {pm.part}, which the file does not "
                                            "define", pm.span))
            elif pm.state != "active":
                out.append(warning("RC624", f"mode {m.name} of {s.name} puts {pm.part} in state {pm.state}: "
                                            "an architecture's components are active (or absent)", pm.span))
            elif pm.mode and pm.mode not in {x.name for x in part.node_modes + part.system_modes}:
                out.append(warning("RC624", f"mode {m.name} of {s.name} names mode {pm.mode}, which {pm.part} "
                                            "does not have", pm.span))
    return out


def _ident(name: str, taken: set[str]) -> str:
    """`name` as a DSL name (`left/manipulator` → `left_manipulator`), not one of `taken`."""
    out = name if _NAME.fullmatch(name) else re.sub(r"\W", "_", name)
    if not out or not _NAME.match(out):
        out = "n_" + out
    return unique(out, taken)


def _stem(file: str) -> str:
    return os.path.splitext(os.path.basename(file))[0] or "imported"
