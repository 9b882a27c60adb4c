"""A reconf node's component as it describes itself (its `reconf.model` parameter: `.arch` text),
parsed by the DSL."""
from __future__ import annotations

from typing import Optional

from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.ir import Component, Document
from reconf_dsl.parser import parse_text

__all__ = ["model_names", "parse_model"]


def parse_model(text: str, where: str = "<reconf.model>") -> Optional[tuple[Document, Component]]:
    """A reconf.model text as (its document, its first component); None if it does not parse or
    declares no component."""
    try:
        doc = parse_text(text, where)
    except DiagnosticError:
        return None
    comp = next((it for it in doc.items if isinstance(it, Component)), None)
    return None if comp is None else (doc, comp)


def model_names(text: str) -> tuple[list[str], list[str]]:
    """The functionalities and ports of the (first) component in a reconf.model text."""
    parsed = parse_model(text)
    if parsed is None:
        return [], []
    comp = parsed[1]
    return [f.name for f in comp.functionalities], [p.name for p in comp.ports]
