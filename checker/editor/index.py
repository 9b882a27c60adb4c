"""Where each name of a system is declared and used: components, ports, functionalities,
connectors, message types, hosts and environment guarantees, for go to definition, find
references, document symbols and hover.

The IR gives each declaration and use a span (the whole statement); the name's own place is
found among the tokens of that span (the lexer's token classes, `lexer.MASTER`), by its place
in the statement: `component NAME`, `output NAME: TYPE`, `COMPONENT.PORT`, a predicate's type
first. A key names what a name stands for: ("component", c), ("port", c, p),
("functionality", c, f), ("connector", n), ("message", m), ("host", h), ("environment", e)."""
from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from typing import Iterator, Optional

from reconf_dsl import ir
from reconf_dsl.lexer import MASTER
from reconf_dsl.span import Span

Key = tuple[str, ...]


@dataclass(frozen=True)
class Token:
    line: int
    col: int
    end_col: int
    text: str


@dataclass(frozen=True)
class Occurrence:
    """A name in a file (1-based line, columns end exclusive): what it stands for, and whether
    it is where that is declared."""

    key: Key
    path: str
    line: int
    col: int
    end_col: int
    decl: bool

    def contains(self, line: int, col: int) -> bool:
        return self.line == line and self.col <= col <= self.end_col


def tokenize(text: str) -> list[Token]:
    """The tokens of `text` (comments left out), as the lexer's token classes split it."""
    starts = [0]
    find = text.find
    at = find("\n")
    while at >= 0:
        starts.append(at + 1)
        at = find("\n", at + 1)
    out: list[Token] = []
    for m in MASTER.finditer(text):
        kind = m.lastgroup
        if kind in (None, "END", "LINE_COMMENT", "BLOCK_COMMENT"):
            continue
        start = m.start(kind)
        line = bisect.bisect_right(starts, start)
        col = start - starts[line - 1] + 1
        value = m.group(kind)
        out.append(Token(line, col, col + len(value), value))
    return out


@dataclass
class FileTokens:
    tokens: list[Token]
    keys: list[tuple[int, int]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.keys = [(t.line, t.col) for t in self.tokens]

    def within(self, span: Span) -> list[Token]:
        lo = bisect.bisect_left(self.keys, (span.line, span.col))
        hi = bisect.bisect_left(self.keys, (span.end_line, span.end_col))
        return self.tokens[lo:hi]

    def after(self, span: Span, most: int = 64) -> list[Token]:
        lo = bisect.bisect_left(self.keys, (span.line, span.col))
        return self.tokens[lo:lo + most]


class Index:
    """Every occurrence of every name in a system's files."""

    def __init__(self) -> None:
        self.by_file: dict[str, list[Occurrence]] = {}
        self.by_key: dict[Key, list[Occurrence]] = {}

    def add(self, key: Key, path: str, tok: Optional[Token], decl: bool = False) -> None:
        if tok is None:
            return
        occ = Occurrence(key, path, tok.line, tok.col, tok.end_col, decl)
        self.by_file.setdefault(path, []).append(occ)
        self.by_key.setdefault(key, []).append(occ)

    def at(self, path: str, line: int, col: int) -> Optional[Occurrence]:
        return next((o for o in self.by_file.get(path, []) if o.contains(line, col)), None)

    def declarations(self, key: Key) -> list[Occurrence]:
        return [o for o in self.by_key.get(key, []) if o.decl]

    def references(self, key: Key, with_declaration: bool = True) -> list[Occurrence]:
        return [o for o in self.by_key.get(key, []) if with_declaration or not o.decl]


def _nth(tokens: list[Token], n: int) -> Optional[Token]:
    return tokens[n] if 0 <= n < len(tokens) else None


def build(documents: dict[str, ir.Document], texts: dict[str, str]) -> Index:
    """The index of `documents` (real path -> document), `texts` their text by real path."""
    index = Index()
    for path, doc in documents.items():
        toks = FileTokens(tokenize(texts.get(path, "")))
        for item in doc.items:
            _item(index, path, toks, item)
    return index


def _item(index: Index, path: str, toks: FileTokens, item: ir.Item) -> None:
    inside = toks.within(item.span)
    if isinstance(item, ir.MessageType):
        index.add(("message", item.name), path, _nth(inside, 1), decl=True)
    elif isinstance(item, ir.EnvGuarantee):
        index.add(("environment", item.name), path, _nth(inside, 1), decl=True)
        _predicate(index, path, toks, item.guarantee)
    elif isinstance(item, ir.Host):
        index.add(("host", item.name), path, _nth(inside, 1), decl=True)
    elif isinstance(item, ir.Component):
        _component(index, path, toks, item, inside)
    elif isinstance(item, ir.Connector):
        index.add(("connector", item.name), path, _nth(inside, 1), decl=True)
        _predicate(index, path, toks, item.guarantee)
        for ref in item.roles:
            parts = toks.within(ref.span)
            index.add(("component", ref.component), path, _nth(parts, 0))
            index.add(("port", ref.component, ref.port), path, _nth(parts, 2))


def _predicate(index: Index, path: str, toks: FileTokens, p: Optional[ir.Predicate]) -> None:
    if p is not None and p.message is not None:
        index.add(("message", p.message), path, _nth(toks.within(p.span), 0))


def _component(index: Index, path: str, toks: FileTokens, c: ir.Component, inside: list[Token]) -> None:
    index.add(("component", c.name), path, _nth(inside, 1), decl=True)
    if c.replaces is not None:
        index.add(("component", c.replaces), path, _nth(inside, 3))
    host_span = getattr(c.host, "span", None)
    if c.host is not None and isinstance(host_span, Span):
        index.add(("host", c.host), path, _nth(toks.within(host_span), 1))
    for port in c.ports:
        parts = toks.within(port.span)
        index.add(("port", c.name, port.name), path, _nth(parts, 1), decl=True)
        if port.kind == "output":
            index.add(("message", port.message), path, _nth(parts, 3))
        _predicate(index, path, toks, port.assumption)
    for f in c.functionalities:
        _functionality(index, path, toks, c, f)
    if c.ftm is not None and c.ftm.hosts:
        for tok in _ftm_hosts(toks.after(c.ftm.span)):
            index.add(("host", tok.text), path, tok)


def _functionality(index: Index, path: str, toks: FileTokens, c: ir.Component, f: ir.Functionality) -> None:
    parts = toks.within(f.span)
    index.add(("functionality", c.name, f.name), path, _nth(parts, 1), decl=True)
    names = set(f.ports)
    for tok in _between_parens(parts):
        if tok.text in names:
            index.add(("port", c.name, tok.text), path, tok)
    for mode in (f.normal, f.degraded):
        if mode is None:
            continue
        for a in mode.assumptions:
            _predicate(index, path, toks, a)
        for g in mode.guarantees:
            index.add(("port", c.name, g.port), path, _nth(toks.within(g.span), 0))
            _predicate(index, path, toks, g.predicate)


def _between_parens(tokens: list[Token]) -> Iterator[Token]:
    inside = False
    for tok in tokens:
        if tok.text == "(":
            inside = True
        elif tok.text == ")":
            return
        elif inside and tok.text != ",":
            yield tok


def _ftm_hosts(tokens: list[Token]) -> Iterator[Token]:
    """The names after `on` in `ftm EXPR on a, b`."""
    seen_on = False
    for tok in tokens:
        if not seen_on:
            seen_on = tok.text == "on"
            if tok.text == "}":
                return
        elif tok.text != ",":
            yield tok
            nxt = tokens.index(tok) + 1
            if nxt >= len(tokens) or tokens[nxt].text != ",":
                return
