"""Files → `System`: reading (UTF-8 only), includes (relative to the including file,
cycles refused), merging every file's items, then name resolution."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Optional

from . import ir
from .diagnostics import Diagnostic, DiagnosticError, Related, error
from .gcpause import gc_paused
from .parser import parse_text
from .resolve import resolve
from .span import Span

MAX_FILE_BYTES = 64 * 1024 * 1024


@dataclass
class Sources:
    """The text of every file read, for caret snippets."""

    texts: dict[str, str] = field(default_factory=dict)

    def line(self, file: str, line: int) -> Optional[str]:
        text = self.texts.get(file)
        if text is None:
            return None
        lines = text.split("\n")
        return lines[line - 1] if 0 < line <= len(lines) else None


def display_path(path: str) -> str:
    rel = os.path.relpath(path)
    return path if rel.startswith("..") else rel


def read_source(path: str, sources: Sources, at: Optional[Span] = None) -> str:
    """Read one file as UTF-8; every failure becomes a diagnostic."""
    shown = display_path(path)
    where = at or Span(shown, 1, 1, 1, 1)
    code = "RC008" if at is not None else "RC007"
    try:
        size = os.path.getsize(path)
        if size > MAX_FILE_BYTES:
            raise DiagnosticError([error("RC010", f"{shown} is {size} bytes; the limit is {MAX_FILE_BYTES}",
                                         Span(shown, 1, 1, 1, 1))])
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        raise DiagnosticError([error(code, f"no such file: {shown}", where)]) from None
    except IsADirectoryError:
        raise DiagnosticError([error(code, f"{shown} is a directory, not an .arch file", where)]) from None
    except OSError as e:
        raise DiagnosticError([error(code, f"cannot read {shown}: {e.strerror}", where)]) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        good = data[: e.start].decode("utf-8", "replace")
        line = good.count("\n") + 1
        col = len(good) - (good.rfind("\n") + 1) + 1
        raise DiagnosticError([error("RC005", f"{shown} is not UTF-8 text (byte 0x{data[e.start]:02x})",
                                     Span(shown, line, col, line, col + 1),
                                     notes=("save the file as UTF-8",))]) from None
    if text.startswith("\ufeff"):
        text = text[1:]
    sources.texts[shown] = text
    return text


def load_documents(paths: list[str], sources: Sources) -> list[ir.Document]:
    """Parse the given files and everything they include, each file once."""
    docs: list[ir.Document] = []
    seen: set[str] = set()
    errors: list[Diagnostic] = []

    def visit(path: str, stack: list[tuple[str, Span]], at: Optional[Span]) -> None:
        real = os.path.realpath(path)
        if any(real == s for s, _ in stack):
            assert at is not None
            chain = [display_path(s) for s, _ in stack] + [display_path(real)]
            errors.append(error("RC009", "include cycle: " + " → ".join(chain), at,
                                related=tuple(Related(sp, "included here") for _, sp in stack[1:])))
            return
        if real in seen:
            return
        seen.add(real)
        try:
            text = read_source(path, sources, at)
            if not text.strip() and at is None:
                raise DiagnosticError([error("RC006", f"{display_path(path)} is empty: nothing to check",
                                             Span(display_path(path), 1, 1, 1, 1),
                                             notes=("an architecture starts with `system NAME`",))])
            doc = parse_text(text, display_path(path))
        except DiagnosticError as e:
            errors.extend(e.diagnostics)
            return
        docs.append(doc)
        for item in doc.items:
            if isinstance(item, ir.Include):
                target = os.path.join(os.path.dirname(path), item.path)
                visit(target, stack + [(real, item.span)], item.span)

    for p in paths:
        visit(p, [], None)
    if errors:
        raise DiagnosticError(errors)
    return docs


def load(paths: list[str], sources: Optional[Sources] = None) -> ir.System:
    """Read, parse, merge and resolve. Raises DiagnosticError with every error found."""
    sources = sources if sources is not None else Sources()
    with gc_paused():
        return resolve(load_documents(paths, sources))


def load_text(text: str, file: str = "<input>", sources: Optional[Sources] = None) -> ir.System:
    """Parse and resolve one in-memory file (includes are not allowed here)."""
    if sources is not None:
        sources.texts[file] = text
    with gc_paused():
        return resolve([parse_text(text, file)])
