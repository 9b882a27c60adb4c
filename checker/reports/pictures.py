"""System + configuration → `codegen.graph.Picture` (what is degraded is decided here);
plans → one picture per step, or one picture of the whole plan."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from typing import Any, Optional

from checker.semantic_model.config import Configuration, Role
from codegen.graph import GraphEdge, GraphNode, Picture
from reconf_dsl.ir import System
from reconf_dsl.words import agree

# Graphviz `dot` takes time that grows steeply with a picture's nodes (components, connectors,
# environment inputs), so a larger picture is drawn as SVG only when asked to be (`--force`);
# the times measured are in bench/README.md ("Pictures").
SVG_MAX_NODES = 400

# What an output file's extension says of its format; the image formats reconf does not write.
PICTURE_EXTENSIONS = {".dot": "dot", ".gv": "dot", ".svg": "svg", ".mmd": "mermaid", ".md": "markdown"}
IMAGE_EXTENSIONS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".gif": "GIF", ".pdf": "PDF",
                    ".ps": "PostScript", ".eps": "PostScript", ".bmp": "BMP", ".webp": "WebP",
                    ".tif": "TIFF", ".tiff": "TIFF"}
FORMAT_NAMES = {"dot": "Graphviz DOT source", "svg": "SVG", "mermaid": "a Mermaid diagram",
                "markdown": "Markdown (Mermaid in a fenced block)"}


class GraphvizUnavailable(Exception):
    """Graphviz `dot` is not installed (or failed): SVG cannot be drawn."""


def largest(pics: list[Picture]) -> int:
    """The most nodes of any of `pics` (what `dot` would lay out at once)."""
    return max((len(p.nodes) for p in pics), default=0)


def format_of_output(picture_format: Optional[str], output: Optional[str]) -> str:
    """The format to write: `picture_format` when given, else the one `output`'s extension says,
    else dot. Raises ValueError (its text in the user's words) when the two contradict, or the
    extension names an image format reconf does not write."""
    stem, ext = os.path.splitext(output or "")
    said = PICTURE_EXTENSIONS.get(ext.lower())
    image = IMAGE_EXTENSIONS.get(ext.lower())
    if image is not None:
        given = f" (--format {picture_format} writes {FORMAT_NAMES[picture_format]})" if picture_format else ""
        right = next(e for e, f in PICTURE_EXTENSIONS.items() if f == (picture_format or "svg"))
        raise ValueError(f"-o {output} asks for {image}, which reconf does not draw{given}; name the file "
                         f"{stem}{right}, or write {stem}.dot and render it with "
                         f"`dot -T{ext[1:].lower()} {stem}.dot -o {output}`")
    if picture_format is None:
        return said or "dot"
    if said is not None and said != picture_format:
        right = next(e for e, f in PICTURE_EXTENSIONS.items() if f == picture_format)
        raise ValueError(f"-o {output} says {FORMAT_NAMES[said]}, but --format {picture_format} writes "
                         f"{FORMAT_NAMES[picture_format]}; name the file {stem}{right}, "
                         f"or leave out --format to write {FORMAT_NAMES[said]}")
    return picture_format


def series(output: str, count: int) -> list[str]:
    """The files of a series of `count` pictures written to `output`: STEM-01.EXT, STEM-02.EXT, …"""
    stem, ext = os.path.splitext(output)
    return [f"{stem}-{i:02d}{ext}" for i in range(1, count + 1)]


def stale(output: str, written: list[str]) -> list[str]:
    """Files of an earlier series to `output` that this one did not write: exactly STEM-NN.EXT
    (NN as the series numbers them, 01, 02, …, 100), in the order of their numbers."""
    stem, ext = os.path.splitext(output)
    folder, base = os.path.split(stem)
    pattern = re.compile(re.escape(base) + r"-(\d+)" + re.escape(ext))
    mine = {os.path.abspath(w) for w in written}
    found = []
    try:
        names = os.listdir(folder or ".")
    except OSError:
        return []
    for name in names:
        m = pattern.fullmatch(name)
        if m is None or f"{int(m.group(1)):02d}" != m.group(1) or int(m.group(1)) < 1:
            continue
        path = os.path.join(folder, name)
        if os.path.abspath(path) not in mine and os.path.isfile(path):
            found.append((int(m.group(1)), path))
    return [p for _, p in sorted(found)]


def picture(system: System, config: Optional[Configuration] = None, *, title: Optional[str] = None,
            removed: frozenset[str] = frozenset(), created: frozenset[str] = frozenset(),
            removed_roles: frozenset[Role] = frozenset(), created_roles: frozenset[Role] = frozenset(),
            notes: Optional[dict[str, str]] = None) -> Picture:
    """`notes` adds a line under a component's name. Roles in `removed_roles` are drawn (dashed,
    red) although `config` no longer has them; `created_roles` are green."""
    config = config or Configuration.initial(system)
    notes = notes or {}
    pic = Picture(title or system.name)
    catalogue = {c.name: c for c in system.components + system.versions}
    shown = sorted(config.components | removed)
    for name in shown:
        comp = catalogue[name]
        degraded = [f.name for f in comp.functionalities if (name, f.name) in config.degraded]
        status = "removed" if name in removed else "created" if name in created else \
            "degraded" if degraded else "normal"
        tip = ("degraded: " + ", ".join(degraded)) if degraded else ""
        label = name + (f"\n{notes[name]}" if name in notes else "")
        pic.nodes.append(GraphNode("c:" + name, label, "ellipse", status, tip))
    for conn in system.connectors:
        label = f"{conn.name}\n{conn.guarantee}"
        pic.nodes.append(GraphNode("t:" + conn.name, label, "box"))
    for env in system.environment:
        pic.nodes.append(GraphNode("e:" + env.name, f"{env.name}\n{env.guarantee}", "note"))
    present = set(shown)
    for conn_name, comp_name, port in sorted(config.roles | removed_roles):
        owner = catalogue.get(comp_name)
        if owner is None or comp_name not in present:
            continue
        p = owner.port(port)
        if p is None:
            continue
        role = (conn_name, comp_name, port)
        status = "removed" if comp_name in removed or role in removed_roles else \
            "created" if role in created_roles else "normal"
        if p.kind == "output":
            pic.edges.append(GraphEdge("c:" + comp_name, "t:" + conn_name, port, status))
        else:
            pic.edges.append(GraphEdge("t:" + conn_name, "c:" + comp_name, port, status))
    return pic


def step_pictures(plan: Any) -> list[Picture]:
    """The configuration after each step of `plan`: what the step created is green, what it
    removed or detached red, what is degraded after it orange."""
    pics = []
    for i, (action, before, after) in enumerate(zip(plan.steps, plan.states, plan.states[1:]), 1):
        pics.append(picture(plan.system, after, title=f"step {i}/{len(plan.steps)}: {action.symbol} {action.describe()}",
                            removed=frozenset(before.components - after.components),
                            created=frozenset(after.components - before.components),
                            removed_roles=frozenset(before.roles - after.roles),
                            created_roles=frozenset(after.roles - before.roles)))
    return pics


def _ranges(steps: list[int]) -> str:
    out: list[str] = []
    for s in steps:
        if out and s == int(out[-1].split("–")[-1]) + 1:
            out[-1] = f"{out[-1].split('–')[0]}–{s}"
        else:
            out.append(str(s))
    return ", ".join(out)


def plan_picture(plan: Any, title: Optional[str] = None) -> Picture:
    """One picture of the whole plan: created green, removed red, degraded at some step orange
    (with the steps under its name); attachments made green, detachments dashed red."""
    first, last = plan.states[0], plan.states[-1]
    steps: dict[tuple[str, str], list[int]] = {}
    for i, state in enumerate(plan.states[1:], 1):
        for d in state.degraded:
            if d[0] in state.components:
                steps.setdefault(d, []).append(i)
    notes: dict[str, str] = {}
    for (c, f), ss in sorted(steps.items()):
        line = f"↓ {f}: {agree(len(ss), 'step', 'steps')} {_ranges(ss)}"
        notes[c] = notes[c] + "\n" + line if c in notes else line
    degraded = frozenset(steps) | last.degraded
    shown = Configuration(frozenset(last.components), degraded, frozenset(last.roles))
    return picture(plan.system, shown, title=title or f"{plan.system.name}: {plan.summary()}",
                   removed=frozenset(first.components - last.components),
                   created=frozenset(last.components - first.components),
                   removed_roles=frozenset(first.roles - last.roles),
                   created_roles=frozenset(last.roles - first.roles), notes=notes)


def to_svg(dot: str) -> str:
    """Render DOT through Graphviz; GraphvizUnavailable says what to install."""
    exe = shutil.which("dot")
    if exe is None:
        raise GraphvizUnavailable("Graphviz `dot` is not installed, so SVG cannot be drawn")
    done = subprocess.run([exe, "-Tsvg"], input=dot, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise GraphvizUnavailable(f"Graphviz `dot` failed: {done.stderr.strip()}")
    return done.stdout
