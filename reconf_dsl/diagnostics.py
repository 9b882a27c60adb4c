"""Diagnostics as data: every stage returns these, one renderer per output format prints them."""
from __future__ import annotations

import enum
from dataclasses import dataclass, field

from .span import Span


class Severity(str, enum.Enum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True)
class Related:
    span: Span
    message: str
    depth: int = 0  # nesting when related spans form a chain (an explanation)


@dataclass(frozen=True)
class Diagnostic:
    code: str
    severity: Severity
    message: str
    span: Span
    related: tuple[Related, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR


def error(code: str, message: str, span: Span, *, related: tuple[Related, ...] = (),
          notes: tuple[str, ...] = ()) -> Diagnostic:
    return Diagnostic(code, Severity.ERROR, message, span, related, notes)


def warning(code: str, message: str, span: Span, *, related: tuple[Related, ...] = (),
            notes: tuple[str, ...] = ()) -> Diagnostic:
    return Diagnostic(code, Severity.WARNING, message, span, related, notes)


class DiagnosticError(Exception):
    """Raised when a stage cannot go on; carries every diagnostic found so far."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = diagnostics
        super().__init__("; ".join(f"{d.span}: {d.code} {d.message}" for d in diagnostics))


@dataclass
class DiagnosticSink:
    items: list[Diagnostic] = field(default_factory=list)

    def add(self, d: Diagnostic) -> None:
        self.items.append(d)

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.items)

    def raise_if_errors(self) -> None:
        if self.has_errors:
            raise DiagnosticError(sorted(self.items, key=lambda d: (d.span.file, d.span.line, d.span.col)))


def shorten(text: str, most: int) -> str:
    """A token or value as a message quotes it: at most `most` characters (an input may hold megabytes)."""
    return text if len(text) <= most else text[:most] + "…"
