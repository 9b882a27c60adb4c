"""Names made unique within a set of names already taken: `name`, else `name_2`, `name_3`…"""
from __future__ import annotations

__all__ = ["unique"]


def unique(name: str, taken: set[str]) -> str:
    """`name`, or `name_2`, `name_3`… when taken; the result is taken from then on."""
    out, n = name, 1
    while out in taken:
        n += 1
        out = f"{name}_{n}"
    taken.add(out)
    return out
