"""Source positions. Every IR node carries one; they never take part in equality."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, order=True)
class Span:
    """A region of a source file: 1-based line and column, end exclusive."""

    file: str
    line: int
    col: int
    end_line: int
    end_col: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"

    @staticmethod
    def unknown(file: str = "<unknown>") -> "Span":
        return Span(file, 1, 1, 1, 1)


NO_SPAN = Span.unknown("<generated>")


_new = object.__new__


def make_span(file: str, line: int, col: int, end_line: int, end_col: int) -> Span:
    """`Span(file, line, col, end_line, end_col)`, the same object, made without the frozen
    dataclass's `__init__` (five `object.__setattr__` calls): the parser makes one for every
    node of every file, and this takes a third of the time."""
    span: Span = _new(Span)
    fields = span.__dict__
    fields["file"] = file
    fields["line"] = line
    fields["col"] = col
    fields["end_line"] = end_line
    fields["end_col"] = end_col
    return span
