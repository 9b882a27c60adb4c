"""A package's names loaded on first use (PEP 562): importing one module of the package, or one
name, does not import every module it gathers (a cold `reconf check` imports no planner and
starts the JVM from `checker.alloy.jvm` before anything else is loaded).

    # checker/x/__init__.py
    from checker.exports import lazy
    if TYPE_CHECKING:                        # what type checkers and readers see
        from checker.x.a import A
    __all__, __getattr__ = lazy(__name__, {"a": ("A",)})
"""
from __future__ import annotations

import importlib
from typing import Any, Callable


def lazy(package: str, table: dict[str, tuple[str, ...]]) -> tuple[list[str], Callable[[str], Any]]:
    """`__all__` and the module `__getattr__` of `package`, whose names are those of `table`
    (submodule -> the names it defines)."""
    where = {name: module for module, names in table.items() for name in names}
    namespace = importlib.import_module(package).__dict__

    def getattr_(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        namespace[name] = value
        return value

    return sorted(where), getattr_
