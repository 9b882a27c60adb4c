"""`Document` → canonical text. Comments are kept: each is placed before the first emitted
line that came from later in the source, or at the end of the line it trailed."""
from __future__ import annotations

from typing import Optional

from . import ir
from .parser import quote

INDENT = "  "
WRAP_AT = 4  # attachments with more port references than this get one line each


class _Out:
    def __init__(self) -> None:
        self.lines: list[tuple[int, int, str]] = []  # (source line, depth, text)

    def emit(self, src: int, depth: int, text: str) -> None:
        self.lines.append((src, depth, text))

    def blank(self) -> None:
        if self.lines and self.lines[-1][2] != "":
            self.lines.append((self.lines[-1][0], 0, ""))


def pred(p: ir.Predicate) -> str:
    return str(p)


def _rate_text(r: ir.Rate) -> str:
    return f"{ir.format_number(r.value)} {r.unit}"


def format_document(doc: ir.Document) -> str:
    out = _Out()
    if doc.system is not None:
        out.emit(doc.system_span.line, 0, f"system {doc.system}")
    prev: Optional[type] = None
    for item in doc.items:
        compact = type(item) is prev and isinstance(item, (ir.MessageType, ir.EnvGuarantee, ir.Include))
        if not compact:
            out.blank()
        _item(out, item)
        prev = type(item)
    return _weave(out.lines, doc.comments)


def _item(out: _Out, it: ir.Item) -> None:
    line = it.span.line
    if isinstance(it, ir.Include):
        out.emit(line, 0, f"include {quote(it.path)}")
    elif isinstance(it, ir.MessageType):
        out.emit(line, 0, f"message {it.name} = {it.ros_type}")
    elif isinstance(it, ir.EnvGuarantee):
        out.emit(line, 0, f"environment {it.name}: {pred(it.guarantee)}")
    elif isinstance(it, ir.Host):
        _block(out, line, 0, f"host {it.name}", [(r.span.line, f"{r.name}: {r.value}") for r in it.resources],
               it.span.end_line)
    elif isinstance(it, ir.Component):
        _component(out, it)
    elif isinstance(it, ir.Connector):
        head = f"{it.kind} {it.name}: {pred(it.guarantee)}" + (" single" if it.single else "")
        refs = len(it.publishers) + len(it.subscribers)
        body: list[tuple[int, str]] = []
        if refs == 0:
            pass
        elif refs <= WRAP_AT:
            src = (it.publishers + it.subscribers)[0].span.line
            body.append((src, _refs(it.publishers) + (" -> " if it.publishers else "-> ") + _refs(it.subscribers)))
            body[-1] = (src, body[-1][1].rstrip())
        else:
            # Newlines mean nothing to the grammar: publishers continue with commas up to one '->',
            # then each subscriber has its own '-> x' line.
            last = len(it.publishers) - 1
            body += [(r.span.line, f"{r}{' ->' if i == last else ','}") for i, r in enumerate(it.publishers)]
            body += [(r.span.line, f"-> {r}") for r in it.subscribers]
        _block(out, line, 0, head, body, it.span.end_line)


def _refs(refs: tuple[ir.PortRef, ...]) -> str:
    return ", ".join(str(r) for r in refs)


def _block(out: _Out, line: int, depth: int, head: str, body: list[tuple[int, str]], end: int) -> None:
    if not body:
        out.emit(line, depth, head + " { }")
        return
    out.emit(line, depth, head + " {")
    for src, text in body:
        out.emit(src, depth + 1, text)
    out.emit(end, depth, "}")


def _component(out: _Out, c: ir.Component) -> None:
    head = f"component {c.name}" + (f" replaces {c.replaces}" if c.replaces else "")
    out.emit(c.span.line, 0, head + " {")
    line = c.span.line
    if c.run is not None:
        out.emit(line, 1, f"run {quote(c.run)}")
    if c.host is not None:
        out.emit(line, 1, f"host {c.host}")
    if c.faults:
        out.emit(line, 1, "faults " + ", ".join(c.faults))
    if c.application:
        out.emit(line, 1, "application " + ", ".join(c.application))
    if c.resources:
        _block(out, c.resources[0].span.line, 1, "resources",
               [(r.span.line, f"{r.name}: {r.value}") for r in c.resources], c.resources[-1].span.end_line)
    if c.ftm is not None:
        text = f"ftm {c.ftm.expr}" + (" on " + ", ".join(c.ftm.hosts) if c.ftm.hosts else "")
        out.emit(c.ftm.span.line, 1, text)
    for p in c.ports:
        if p.kind == "input":
            assert p.assumption is not None
            out.emit(p.span.line, 1, f"input {p.name}: {pred(p.assumption)}")
        else:
            out.emit(p.span.line, 1, f"output {p.name}: {p.message}")
    for f in c.functionalities:
        out.blank()
        crit = f" criticality {f.criticality}" if f.criticality != 1 else ""
        out.emit(f.span.line, 1, f"functionality {f.name} ({', '.join(f.ports)}){crit} {{")
        for mode in (f.normal, f.degraded):
            if mode is None:
                continue
            body = [(a.span.line, f"assume {pred(a)}") for a in mode.assumptions]
            body += [(g.span.line, f"{g.port}: {pred(g.predicate)}") for g in mode.guarantees]
            if len(body) == 1:
                out.emit(mode.span.line, 2, f"{mode.kind} {{ {body[0][1]} }}")
            else:
                _block(out, mode.span.line, 2, mode.kind, body, mode.span.end_line)
        out.emit(f.span.end_line, 1, "}")
    out.emit(c.span.end_line, 0, "}")


def _weave(lines: list[tuple[int, int, str]], comments: tuple[tuple[int, int, str], ...]) -> str:
    """Put every comment back: trailing the line it trailed, else before the first line from later on."""
    pending = sorted(comments)
    text: list[str] = []
    srcs: list[int] = []

    def place(cline: int, ctext: str, depth: int) -> None:
        j = len(text) - 1
        while j >= 0 and text[j] == "":
            j -= 1
        if j >= 0 and srcs[j] == cline and "\n" not in ctext:
            text[j] += "  " + ctext
            return
        for k, part in enumerate(ctext.split("\n")):
            text.append(INDENT * depth + part.strip() if k == 0 else part.rstrip())
            srcs.append(-1)

    ci = 0
    for src, depth, body in lines:
        while ci < len(pending) and pending[ci][0] < src:
            place(pending[ci][0], pending[ci][2], depth)
            ci += 1
        text.append((INDENT * depth + body) if body else "")
        srcs.append(src)
    for cline, _, ctext in pending[ci:]:
        place(cline, ctext, 0)
    while text and text[-1] == "":
        text.pop()
    return "\n".join(text) + "\n"
