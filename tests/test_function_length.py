"""No function in reconf_dsl, checker or codegen runs over `LIMIT` lines, so each can be read in
one sitting; the few that still do are named here, each with the reason it stays."""
from __future__ import annotations

import ast
from pathlib import Path
from typing import Iterator, Union

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("reconf_dsl", "checker", "codegen", "reconf_ros")
LIMIT = 60

# qualified name → why it is still longer than LIMIT
ALLOWED = {
    "reconf_dsl.lexer.Driver.parse": "the hot loop: it lexes and parses every token, and a call per token "
                                     "would slow every load",
}

Function = Union[ast.FunctionDef, ast.AsyncFunctionDef]


def _functions(node: ast.AST, prefix: str) -> Iterator[tuple[str, Function]]:
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield prefix + child.name, child
            yield from _functions(child, f"{prefix}{child.name}.")
        elif isinstance(child, ast.ClassDef):
            yield from _functions(child, f"{prefix}{child.name}.")


def lengths() -> dict[str, int]:
    """Every function's qualified name → its lines, from `def` to its last line."""
    out: dict[str, int] = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for name, f in _functions(tree, module + "."):
                out[name] = (f.end_lineno or f.lineno) - f.lineno + 1
    return out


def test_no_function_is_longer_than_the_limit() -> None:
    long = {name: n for name, n in lengths().items() if n > LIMIT and name not in ALLOWED}
    assert not long, f"functions over {LIMIT} lines (split them, or name them in ALLOWED with why): {long}"


def test_every_allowed_function_exists_and_is_still_long() -> None:
    found = lengths()
    stale = {name for name in ALLOWED if found.get(name, 0) <= LIMIT}
    assert not stale, f"no longer over {LIMIT} lines (or gone): take them out of ALLOWED: {sorted(stale)}"
