"""reconf's diagnostics and spans as the Language Server Protocol's types (lsprotocol).

A span is 1-based with columns in code points; an LSP position is 0-based with columns in the
units the client and server agreed on (UTF-16 by default): `codec` (pygls's PositionCodec)
converts, given the lines of the file."""
from __future__ import annotations

from typing import Any, Callable, Optional
from urllib.parse import unquote, urlparse

from lsprotocol import types as lsp

from reconf_dsl.diagnostics import Diagnostic, Severity
from reconf_dsl.span import Span

SEVERITY = {Severity.ERROR: lsp.DiagnosticSeverity.Error, Severity.WARNING: lsp.DiagnosticSeverity.Warning,
            Severity.NOTE: lsp.DiagnosticSeverity.Information}
SOURCE = "reconf"

Lines = Callable[[str], list[str]]      # a real path -> its lines, for position units


def uri_of(path: str) -> str:
    from pathlib import Path

    return Path(path).as_uri()


def path_of(uri: str) -> str:
    parsed = urlparse(uri)
    return unquote(parsed.path) if parsed.scheme == "file" else uri


def position(codec: Any, lines: list[str], line: int, col: int) -> lsp.Position:
    """1-based (line, column in code points) as the client's position."""
    return codec.position_to_client_units(lines, lsp.Position(max(0, line - 1), max(0, col - 1)))  # type: ignore[no-any-return]


def to_range(codec: Any, lines: list[str], line: int, col: int, end_line: int, end_col: int) -> lsp.Range:
    if (end_line, end_col) < (line, col):
        end_line, end_col = line, col
    return lsp.Range(position(codec, lines, line, col), position(codec, lines, end_line, end_col))


def span_range(codec: Any, lines: list[str], span: Span) -> lsp.Range:
    return to_range(codec, lines, span.line, span.col, span.end_line, span.end_col)


def from_position(codec: Any, lines: list[str], pos: lsp.Position) -> tuple[int, int]:
    """The client's position as 1-based (line, column in code points)."""
    server = codec.position_from_client_units(lines, pos)
    return server.line + 1, server.character + 1


def diagnostic(d: Diagnostic, codec: Any, lines: Lines, absolute: Callable[[str], str]) -> lsp.Diagnostic:
    """One diagnostic: its code, its span, its notes after the message, and its related spans
    (an explanation chain, in order, each indented by its depth) as related information."""
    here = absolute(d.span.file)
    related = []
    for r in d.related:
        if r.span.file.startswith("<"):
            continue
        there = absolute(r.span.file)
        related.append(lsp.DiagnosticRelatedInformation(
            lsp.Location(uri_of(there), span_range(codec, lines(there), r.span)),
            ("  " * max(0, r.depth - 1)) + r.message))
    message = d.message + "".join(f"\nnote: {n}" for n in d.notes)
    return lsp.Diagnostic(range=span_range(codec, lines(here), d.span), message=message,
                          severity=SEVERITY[d.severity], code=d.code, source=SOURCE,
                          related_information=related or None)


def status_diagnostic(message: str, codec: Any, lines: list[str], span: Optional[Span],
                      severity: lsp.DiagnosticSeverity, code: str) -> lsp.Diagnostic:
    """A verdict shown at the system's declaration (the Alloy proof's, for one)."""
    where = (span_range(codec, lines, span) if span is not None
             else lsp.Range(lsp.Position(0, 0), lsp.Position(0, 0)))
    return lsp.Diagnostic(range=where, message=message, severity=severity, code=code, source=f"{SOURCE} (Alloy)")
