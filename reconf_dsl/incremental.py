"""Parsing a file again after an edit, from its parse before the edit: what an editor does as
the user types (the language server, the warm analyzer).

A file is a sequence of top-level items (`start: item*`), and the parser is in the same state
between any two of them, so the items an edit does not reach keep what the parse of the text
before said of them. `Incremental.parse(text, file)` compares the new text with the last text of
that file it parsed: the changes (one from the first difference to the last, split around an
unchanged item found once between them, so that two edits far apart are two small changes),
each widened to whole items with one unchanged item more on each side (a comment records the
tokens before and after it: those at a region's edges see the tokens they saw before). Each
region is parsed alone, padded with blank lines and spaces to its place, so that every position
comes out where it is in the file. The items outside the regions are taken as they were; once a
change added or removed lines, every position after it moved, and its region runs to the end of
the file.

The document is the one the whole text parses to: the same items, spans and comments (tests
hold the two to each other on random edits). When a region does not parse, or two declare a
`system`, the whole text is parsed, so that every diagnostic is the one the whole file gives.
"""
from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from . import ir

Parse = Callable[[str, str], ir.Document]


@dataclass
class _Parsed:
    """A text of a file and its document, with each top-level item's offsets in the text
    (made when a reparse first needs them)."""

    text: str
    document: ir.Document
    _items: Optional[list[tuple[int, int, Any]]] = field(default=None, repr=False)

    def items(self) -> list[tuple[int, int, Any]]:
        """(start, end, item) of every top-level item in order, the `system` declaration as
        the item ("system", name, span); offsets into `text`, end exclusive."""
        if self._items is None:
            starts = [0]
            find = self.text.find
            at = find("\n")
            while at >= 0:
                starts.append(at + 1)
                at = find("\n", at + 1)
            doc = self.document
            found: list[tuple[Any, Any]] = [(i.span, i) for i in doc.items]
            if doc.system is not None:
                found.append((doc.system_span, ("system", doc.system, doc.system_span)))
            self._items = sorted(((starts[s.line - 1] + s.col - 1, starts[s.end_line - 1] + s.end_col - 1, i)
                                  for s, i in found), key=lambda x: x[0])
        return self._items


class Incremental:
    """The last parse of each file; `parse` parses a new text of it from there (see above).
    `reparsed` and `whole` count how the texts were parsed."""

    def __init__(self, parse: Parse) -> None:
        self._parse = parse
        self._last: dict[str, _Parsed] = {}
        self.reparsed = self.whole = 0

    def parse(self, text: str, file: str) -> ir.Document:
        """`text` (of `file`) parsed; raises DiagnosticError as the parse of the whole text does."""
        last = self._last.get(file)
        document = _reparse(last, text, file, self._parse) if last is not None else None
        if document is None:
            document = self._parse(text, file)     # on an error, the last parse stays the one to start from
            self.whole += 1
        else:
            self.reparsed += 1
        self._last[file] = _Parsed(text, document)
        return document


def _common(a: str, b: str) -> tuple[int, int]:
    """The lengths of the longest common prefix and of the longest common suffix of a and b
    that does not overlap it."""
    n = min(len(a), len(b))
    lo, hi = 0, n                  # a[:lo] == b[:lo]; binary search on slices compared in C
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if a[lo:mid] == b[lo:mid]:
            lo = mid
        else:
            hi = mid - 1
    prefix = lo
    lo, hi = 0, n - prefix
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if a[len(a) - mid:len(a) - lo] == b[len(b) - mid:len(b) - lo]:
            lo = mid
        else:
            hi = mid - 1
    return prefix, lo


Change = tuple[int, int, int, int]      # before[a0:b0] became text[a1:b1]


def _changes(before: str, text: str, items: list[tuple[int, int, Any]], lo0: int, hi0: int, lo1: int,
             hi1: int) -> list[Change]:
    """Where before[lo0:hi0] and text[lo1:hi1] differ, as changes in order with equal text
    between them: one change from their first to their last difference, split around an item
    that lies, once, unchanged between the two (an editor's find-and-replace, or two edits
    far apart, are two small changes rather than one as large as the file)."""
    prefix, suffix = _common(before[lo0:hi0], text[lo1:hi1])
    a0, b0, a1, b1 = lo0 + prefix, hi0 - suffix, lo1 + prefix, hi1 - suffix
    if a0 == b0 and a1 == b1:
        return []
    inside = [(start, end) for start, end, _ in items if a0 < start and end < b0]
    if len(inside) >= 3:
        start, end = inside[len(inside) // 2]
        piece = before[start:end]
        at = text.find(piece, a1 + 1, b1 - 1)
        if at >= 0 and text.find(piece, at + 1, b1 - 1) < 0:
            return (_changes(before, text, items, a0, start, a1, at)
                    + _changes(before, text, items, end, b0, at + len(piece), b1))
    return [(a0, b0, a1, b1)]


def _reparse(last: _Parsed, text: str, file: str, parse: Parse) -> Optional[ir.Document]:
    before, old = last.text, last.document
    if text == before:
        return old
    items = last.items()
    regions = _regions(before, text, items, _changes(before, text, items, 0, len(before), 0, len(text)))
    parsed: list[tuple[int, int, ir.Document]] = []
    for k, m, start, end in regions:
        region = _parse_region(text, start, end, file, parse)
        if region is None:
            return None
        parsed.append((k, m, region))
    return _merge(old, before, items, parsed, file)


def _regions(before: str, text: str, items: list[tuple[int, int, Any]],
             changes: list[Change]) -> list[tuple[int, int, int, int]]:
    """The regions to parse again, as (k, m, start, end): items k to m of `items` (k = -1: from
    the start of the file; m = len(items): to its end) and where they are in `text`. Each
    change reaches from the last item that ends before it, with a character between, to the
    first that starts after it, with a character between, on a later line; when the changes
    so far added or removed lines, to the end of the file (every position after moved).
    Regions that meet are one."""
    starts, ends = [s for s, _, _ in items], [e for _, e, _ in items]
    out: list[list[int]] = []
    lines = 0
    for a0, b0, a1, b1 in changes:
        k = bisect.bisect_left(ends, a0) - 1
        lines += text.count("\n", a1, b1) - before.count("\n", a0, b0)
        m = len(items)
        if lines == 0:
            newline = before.find("\n", b0)
            m = bisect.bisect_left(starts, max(len(before) if newline < 0 else newline + 1, b0 + 1))
        shift_before, shift_after = a1 - a0, b1 - b0
        start = items[k][0] + shift_before if k >= 0 else 0
        end = items[m][1] + shift_after if m < len(items) else len(text)
        if out and k <= out[-1][1]:
            out[-1][1], out[-1][3] = m, end
        else:
            out.append([k, m, start, end])
        if m == len(items):
            break
    return [(k, m, start, end) for k, m, start, end in out]


def _parse_region(text: str, start: int, end: int, file: str, parse: Parse) -> Optional[ir.Document]:
    """text[start:end] parsed alone, every position where it is in `text`; None when it does
    not parse."""
    from .diagnostics import DiagnosticError

    line = text.count("\n", 0, start)
    col = start - (text.rfind("\n", 0, start) + 1)
    try:
        return parse("\n" * line + " " * col + text[start:end], file)
    except DiagnosticError:
        return None


def _position(text: str, offset: int) -> tuple[int, int]:
    """The (line, column) of `offset` in `text`, 1-based."""
    return text.count("\n", 0, offset) + 1, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _merge(old: ir.Document, before: str, items: list[tuple[int, int, Any]],
           parsed: list[tuple[int, int, ir.Document]], file: str) -> Optional[ir.Document]:
    """The document of the items kept (those outside every region) and each region's, with
    their comments; None when two of them declare the system."""
    body: list[Any] = []
    comments: list[Any] = []
    systems: list[tuple[Optional[str], ir.Span]] = []
    kept_from, comment_from = 0, (0, 0)        # the next item, and where the next comment, to keep
    for k, m, region in parsed:
        kept_to = max(k, 0)
        _keep(items[kept_from:kept_to], body, systems)
        until = _position(before, items[k][0]) if k >= 0 else (0, 0)
        comments += [c for c in old.comments if comment_from <= (c[0], c.col) < until]  # type: ignore[attr-defined]
        body += region.items
        comments += region.comments
        if region.system is not None:
            systems.append((region.system, region.system_span))
        kept_from = m + 1
        comment_from = _position(before, items[m][1]) if m < len(items) else (len(before) + 1, 0)
    _keep(items[kept_from:], body, systems)
    comments += [c for c in old.comments if comment_from <= (c[0], c.col)]  # type: ignore[attr-defined]
    if len(systems) > 1:
        return None
    system, system_span = systems[0] if systems else (None, ir.Span(file, 1, 1, 1, 1))
    return ir.Document(file, system, tuple(body), system_span, tuple(comments))


def _keep(kept: list[tuple[int, int, Any]], body: list[Any], systems: list[tuple[Optional[str], ir.Span]]) -> None:
    for _, _, item in kept:
        if isinstance(item, tuple):
            systems.append((item[1], item[2]))
        else:
            body.append(item)
