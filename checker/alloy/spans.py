"""From a position in a generated Alloy module back to the DSL declaration it came from.

Every atom of an instance or plan module is a mangled DSL name, and the renderer returns
the map from atom to what it stands for. An Alloy error (`AlloyError` with module, line
and column) is mapped to the atom nearest its position on that line: the one under the
column, else the nearest to its left, else to its right; of these, the first that stands
for a component, port, functionality or connector, whose declaration span is returned.
Data atoms (message types with rates) are skipped: they have no declaration of their own.
"""
from __future__ import annotations

import re
from typing import Any, Mapping, Optional

from checker.alloy.errors import AlloyError
from reconf_dsl.span import Span

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def entity_span(system: Any, meaning: tuple[str, ...]) -> Optional[Span]:
    """The declaration span of the DSL entity an atom stands for, if it has one."""
    kind = meaning[0]
    if kind == "connector":
        k = system.connector(meaning[1])
        return k.span if k is not None else None
    if kind not in ("component", "port", "functionality"):
        return None
    comp = system.component(meaning[1])
    if comp is None:
        return None
    if kind == "component":
        return comp.span  # type: ignore[no-any-return]
    if kind == "port":
        port = comp.port(meaning[2])
        return port.span if port is not None else None
    func = next((f for f in comp.functionalities if f.name == meaning[2]), None)
    return func.span if func is not None else None


def span_at(text: str, line: int, column: int, names: Mapping[str, tuple[str, ...]],
            system: Any) -> Optional[Span]:
    """The DSL span for 1-based (line, column) of the module `text`, whose atoms `names` maps."""
    lines = text.splitlines()
    if not 1 <= line <= len(lines):
        return None
    tokens = [(m.start() + 1, m.end() + 1, m.group()) for m in IDENTIFIER.finditer(lines[line - 1])]
    under = [t for t in tokens if t[0] <= column < t[1]]
    left = sorted((t for t in tokens if t[1] <= column), key=lambda t: -t[0])
    right = [t for t in tokens if t[0] > column]
    for _, _, token in under + left + right:
        if token in names:
            span = entity_span(system, names[token])
            if span is not None:
                return span
    return None


def dsl_span_for(error: AlloyError, text: str, names: Mapping[str, tuple[str, ...]],
                 system: Any) -> Optional[Span]:
    """The DSL span for an error Alloy reported in the module `text` (None when the error
    has no position or points at no DSL entity, e.g. in the shared semantics)."""
    if not error.line:
        return None
    return span_at(text, error.line, error.column, names, system)


def with_span(error: AlloyError, text: str, names: Mapping[str, tuple[str, ...]], system: Any) -> AlloyError:
    """`error` with `span` set from its position, for raising again."""
    error.span = dsl_span_for(error, text, names, system)
    return error
