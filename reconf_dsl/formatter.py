"""`Document` → canonical text, every comment kept where it was.

Each line written knows where in the source its first token was (its key). A comment with a
token before it on its line trails the line with the last key at or before it: it stays at the
end of the line of what it followed. Any other comment goes on lines of its own above the line
that holds the token after it (indented as that line, one step deeper above a closing brace): it
stays above what it preceded, and moves with it when the canonical layout puts statements in
another order; when that token is inside a line that began before the comment, the comment
trails that line. Comments between two keys keep their order. A block that holds a comment is
not joined onto one line, and nothing is put after a `//` comment: a comment that would be goes
above the next line. An empty line before or after a comment on lines of its own is kept (one
at most), except just inside a brace.
"""
from __future__ import annotations

from bisect import bisect_right
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

from . import ir
from .lexer import Comment
from .parser import quote
from .span import NO_SPAN, Span

INDENT = "  "
WRAP_AT = 4  # attachments with more port references than this get one line each

Pos = tuple[int, int]  # (line, column) in the source


@dataclass
class _Line:
    key: Optional[Pos]  # None for an empty line
    depth: int
    text: str
    closing: bool = False


class _Out:
    def __init__(self, comments: Sequence[Comment]) -> None:
        self.lines: list[_Line] = []
        self._starts = [c.start for c in comments]  # in source order, so sorted

    def emit(self, key: Pos, depth: int, text: str, closing: bool = False) -> None:
        self.lines.append(_Line(key, depth, text, closing))

    def blank(self) -> None:
        if self.lines and self.lines[-1].key is not None:
            self.lines.append(_Line(None, 0, ""))

    def quiet(self, start: Pos, end: Pos) -> bool:
        """No comment starts after `start` and before `end`."""
        i = bisect_right(self._starts, start)
        return i == len(self._starts) or self._starts[i] >= end


def _at(span: Span) -> Pos:
    return (span.line, span.col)


def _end(span: Span) -> Pos:
    return (span.end_line, span.end_col)


def _brace(span: Span) -> Pos:
    """Where the closing brace that ends `span` is."""
    return (span.end_line, span.end_col - 1)


def _span_of(value: Any, fallback: Span) -> Span:
    """The statement span the parser gives values without a node of their own (`parser.Located`)."""
    span = getattr(value, "span", None)
    return span if isinstance(span, Span) and span != NO_SPAN else fallback


def pred(p: ir.Predicate) -> str:
    return str(p)


def format_document(doc: ir.Document) -> str:
    comments = [_comment(c) for c in doc.comments]
    out = _Out(comments)
    if doc.system is not None:
        out.emit(_at(doc.system_span), 0, f"system {doc.system}")
    prev: Optional[type] = None
    for item in doc.items:
        compact = type(item) is prev and isinstance(item, (ir.MessageType, ir.EnvGuarantee, ir.Include))
        if not compact:
            out.blank()
        _item(out, item)
        prev = type(item)
    return _weave(out.lines, comments)


def _comment(c: tuple[int, int, str]) -> Comment:
    if isinstance(c, Comment):
        return c
    line, end_line, text = c  # a comment without columns: a line of its own
    return Comment(text, line, 1, end_line, len(text) - text.rfind("\n"))


def _item(out: _Out, it: ir.Item) -> None:
    at = _at(it.span)
    if isinstance(it, ir.Include):
        out.emit(at, 0, f"include {quote(it.path)}")
    elif isinstance(it, ir.MessageType):
        out.emit(at, 0, f"message {it.name} = {it.ros_type}")
    elif isinstance(it, ir.EnvGuarantee):
        out.emit(at, 0, f"environment {it.name}: {pred(it.guarantee)}")
    elif isinstance(it, ir.Host):
        _block(out, at, 0, f"host {it.name}", [(_at(r.span), f"{r.name}: {r.value}") for r in it.resources],
               _brace(it.span))
    elif isinstance(it, ir.Component):
        _component(out, it)
    elif isinstance(it, ir.Connector):
        _block(out, at, 0, f"{it.kind} {it.name}: {pred(it.guarantee)}" + (" single" if it.single else ""),
               _attachments(out, it), _brace(it.span))


def _attachments(out: _Out, it: ir.Connector) -> list[tuple[Pos, str]]:
    refs = it.publishers + it.subscribers
    if not refs:
        return []
    # on one line unless a comment is between two references (one after the last trails the line)
    first, last = min(_at(r.span) for r in refs), max(_at(r.span) for r in refs)
    if len(refs) <= WRAP_AT and out.quiet(first, last):
        return [(first, (_refs(it.publishers) + (" -> " if it.publishers else "-> ") + _refs(it.subscribers))
                 .rstrip())]
    # Newlines mean nothing to the grammar: publishers continue with commas up to one '->',
    # then each subscriber has its own '-> x' line.
    end = len(it.publishers) - 1
    return ([(_at(r.span), f"{r}{' ->' if i == end else ','}") for i, r in enumerate(it.publishers)] +
            [(_at(r.span), f"-> {r}") for r in it.subscribers])


def _refs(refs: tuple[ir.PortRef, ...]) -> str:
    return ", ".join(str(r) for r in refs)


def _block(out: _Out, at: Pos, depth: int, head: str, body: list[tuple[Pos, str]], brace: Pos) -> None:
    if not body and out.quiet(at, brace):
        out.emit(at, depth, head + " { }")
        return
    out.emit(at, depth, head + " {")
    for key, text in body:
        out.emit(key, depth + 1, text)
    out.emit(brace, depth, "}", closing=True)


def _component(out: _Out, c: ir.Component) -> None:
    head = f"component {c.name}" + (f" replaces {c.replaces}" if c.replaces else "")
    out.emit(_at(c.span), 0, head + " {")
    if c.run is not None:
        out.emit(_at(_span_of(c.run, c.span)), 1, f"run {quote(c.run)}")
    if c.host is not None:
        out.emit(_at(_span_of(c.host, c.span)), 1, f"host {c.host}")
    if c.node is not None:
        _node(out, c.node)
    if c.faults:
        out.emit(_at(_span_of(c.faults, c.span)), 1, "faults " + ", ".join(c.faults))
    if c.application:
        out.emit(_at(_span_of(c.application, c.span)), 1, "application " + ", ".join(c.application))
    if c.resources:
        where = _span_of(c.resources, c.span)
        at, brace = ((_at(where), _brace(where)) if where is not c.span else
                     (_at(c.resources[0].span), _end(c.resources[-1].span)))
        _block(out, at, 1, "resources", [(_at(r.span), f"{r.name}: {r.value}") for r in c.resources], brace)
    if c.ftm is not None:
        text = f"ftm {c.ftm.expr}" + (" on " + ", ".join(c.ftm.hosts) if c.ftm.hosts else "")
        out.emit(_at(c.ftm.span), 1, text)
    if c.takes:
        out.emit(_at(_span_of(c.takes, c.takes[0].span)), 1, "takes " + ", ".join(map(str, c.takes)))
    for p in c.ports:
        if p.kind == "input":
            assert p.assumption is not None
            out.emit(_at(p.span), 1, f"input {p.name}: {pred(p.assumption)}")
        else:
            out.emit(_at(p.span), 1, f"output {p.name}: {p.message}")
    for f in c.functionalities:
        out.blank()
        crit = f" criticality {f.criticality}" if f.criticality != 1 else ""
        out.emit(_at(f.span), 1, f"functionality {f.name} ({', '.join(f.ports)}){crit} {{")
        for mode in (f.normal, f.degraded):
            if mode is None:
                continue
            body = [(_at(a.span), f"assume {pred(a)}") for a in mode.assumptions]
            body += [(_at(g.span), f"{g.port}: {pred(g.predicate)}") for g in mode.guarantees]
            if len(body) == 1 and out.quiet(_at(mode.span), _brace(mode.span)):
                out.emit(_at(mode.span), 2, f"{mode.kind} {{ {body[0][1]} }}")
            else:
                _block(out, _at(mode.span), 2, mode.kind, body, _brace(mode.span))
        out.emit(_brace(f.span), 1, "}", closing=True)
    out.emit(_brace(c.span), 0, "}", closing=True)


def _node(out: _Out, n: ir.RosNode) -> None:
    _block(out, _at(n.span), 1, node_head(n), [(_at(span), text) for span, text in node_body(n)], _brace(n.span))


def node_head(n: ir.RosNode) -> str:
    return f"node {n.name}" + (" lifecycle" if n.lifecycle else "")


def node_body(n: ir.RosNode) -> list[tuple[Span, str]]:
    """A `node` block's lines: the ports' ROS names, then what each mode means for the node."""
    return [(t.span, f"{t.port} = {t.ros_name}") for t in n.topics] + \
        [(m.span, f"{m.functionality} {m.mode}: " + ", ".join(effect_text(e) for e in m.effects)) for m in n.modes]


def node_block(n: ir.RosNode, indent: str = INDENT) -> list[str]:
    """The `node` block as canonical lines, its first at no indent (a component's text puts it in)."""
    body = [indent + text for _, text in node_body(n)]
    return [node_head(n) + " {", *body, "}"] if body else [node_head(n) + " { }"]


def effect_text(e: ir.Effect) -> str:
    """`deactivate`, `hold` or `set NAME = VALUE`, as the language writes it."""
    return e.kind if e.kind != "set" else f"set {e.param} = {param_text(e.value)}"


def param_text(value: ir.ParamValue) -> str:
    """A parameter value as the language writes it: `true`, `3`, `0.5`, `"text"`."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value) if isinstance(value, int) else quote(value)


Group = list[Comment]  # comments on one line: the first, then those glued to it


def _weave(lines: list[_Line], comments: list[Comment]) -> str:
    """The lines with every comment put back (see the module's docstring)."""
    if not comments:
        plain = [INDENT * ln.depth + ln.text if ln.key is not None else "" for ln in lines]
        while plain and plain[-1] == "":
            plain.pop()
        return "\n".join(plain) + "\n" if plain else ""
    before, after, tail = _assign(lines, comments)
    out = _Writer()
    for i, ln in enumerate(lines):
        if ln.key is None:
            out.blank(kept=False)
            continue
        for group in before.get(i, ()):
            out.group(group, ln.depth + (1 if ln.closing else 0), blank_after=not ln.closing)
        out.text.append(INDENT * ln.depth + ln.text)
        for c in after.get(i, ()):
            out.put(c, None)
        out.opened = ln.text.endswith("{")
    for group in tail:
        out.group(group, 0, blank_after=False)
    return out.result()


def _assign(lines: list[_Line], comments: list[Comment]
            ) -> tuple[dict[int, list[Group]], dict[int, Group], list[Group]]:
    """Where each comment goes: the groups above each line (by index), the comments after each
    line, and the groups after the last line."""
    keyed = sorted((ln.key, i) for i, ln in enumerate(lines) if ln.key is not None)
    keys = [k for k, _ in keyed]
    before: dict[int, list[Group]] = defaultdict(list)
    after: dict[int, Group] = defaultdict(list)
    tail: list[Group] = []
    last: Optional[Group] = None  # the group or trailing list the previous comment went to
    prev: Optional[Comment] = None
    where = (-1, 0)  # where it went: (key index, 0 before that line or 1 after it)
    for c in comments:
        if c.glued and last is not None:
            last.append(c)
            prev = c
            continue
        trails, j = _place(c, keys)
        here = (j, 1 if trails else 0)
        if (prev is not None and here < where and
                bisect_right(keys, prev.start) == bisect_right(keys, c.start)):
            # no key between the two, so the later one may not go first: it follows the earlier
            # one (above the line of a `->`, when the earlier is above that `->` and this after it)
            trails, j = False, where[0]
            here = where
        if trails:
            last = after[keyed[j][1]]
            last.append(c)
        else:
            last = [c]
            (before[keyed[j][1]] if j < len(keys) else tail).append(last)
        prev, where = c, here
    for i in list(after):
        _overflow(i, after, before, tail, lines)
    return before, after, tail


@dataclass
class _Writer:
    """The output lines, and whether the last one written opens a block (no empty line is kept
    after it)."""

    text: list[str] = field(default_factory=list)
    opened: bool = False

    def blank(self, kept: bool = True) -> None:
        if self.text and self.text[-1] != "" and not (kept and self.opened):
            self.text.append("")

    def put(self, c: Comment, depth: Optional[int]) -> None:
        """`c` on a line of its own at `depth`, or (None) after the last line."""
        first, *rest = c.text.split("\n")
        if depth is None:
            self.text[-1] += "  " + first.strip()
        else:
            self.text.append(INDENT * depth + first.strip())
        self.text.extend(part.rstrip() for part in rest)

    def group(self, group: Group, depth: int, blank_after: bool) -> None:
        """A group of comments above a line: the first at `depth`, the glued ones after it."""
        if group[0].blank_before:
            self.blank()
        for k, c in enumerate(group):
            self.put(c, None if k else depth)
        self.opened = False
        if group[-1].blank_after and blank_after:
            self.blank()

    def result(self) -> str:
        while self.text and self.text[-1] == "":
            self.text.pop()
        return "\n".join(self.text) + "\n" if self.text else ""


LEADS = ("assume", "->")  # tokens before a line's key that belong to the line: `assume X`, `-> c.i`


def _place(c: Comment, keys: list[Pos]) -> tuple[bool, int]:
    """(True, j) when `c` trails the line with the j-th key; (False, j) when it goes on lines of its
    own before that line (after the last line when j is past the end)."""
    if c.trailing and keys and keys[0] <= c.start:
        return True, bisect_right(keys, c.start) - 1
    if c.next is None:
        return False, len(keys)
    line, col, token = c.next
    at = (line, col)
    if token in LEADS:
        return False, bisect_right(keys, at)
    j = bisect_right(keys, at) - 1
    if j < 0:
        return False, 0
    # the token after the comment is inside a line that began before it: the comment trails that line
    return keys[j] < c.start, j


def _overflow(i: int, after: dict[int, Group], before: dict[int, list[Group]], tail: list[Group],
              lines: list[_Line]) -> None:
    """Nothing can follow a `//` comment on its line: what would goes before the next line."""
    trailing = after[i]
    cut = next((k + 1 for k, c in enumerate(trailing) if not c.text.startswith("/*")), len(trailing))
    if cut == len(trailing):
        return
    moved: list[Group] = []
    for c in trailing[cut:]:
        if c.glued and moved and moved[-1][-1].end[0] == c.start[0]:
            moved[-1].append(c)
        else:
            moved.append([c])
    del trailing[cut:]
    nxt = next((j for j in range(i + 1, len(lines)) if lines[j].key is not None), None)
    target = before[nxt] if nxt is not None else tail
    target.extend(moved)
    target.sort(key=lambda g: g[0].start)
