"""The Alloy backend: the Alloy 6 jar driven through JPype, reached through one factory.

    from checker.alloy import get_backend
    outcomes = get_backend().run({"main.als": text}, "main.als")

`get_backend()` returns a `Backend` (the protocol every caller uses) or raises
AlloyUnavailable saying what to install.

The names below are loaded on first use (PEP 562), so that importing one submodule (a cold
`reconf check` starts the JVM from `checker.alloy.jvm` before anything else is imported) does
not import them all.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from checker.alloy.bridge import DEFAULT_SOLVER, AlloyBridge, Backend, CommandOutcome, get_backend
    from checker.alloy.errors import AlloyError, AlloyTimeout, AlloyUnavailable
    from checker.alloy.instance import AlloyPlanVerdict, AlloyVerdict, alloy_plan_verdict, alloy_verdict
    from checker.alloy.jvm import find_jar, find_jvm
    from checker.alloy.metamodel import metamodel_modules
    from checker.alloy.worker import run_with_timeout

_WHERE = {
    "bridge": ("DEFAULT_SOLVER", "AlloyBridge", "Backend", "CommandOutcome", "get_backend"),
    "errors": ("AlloyError", "AlloyTimeout", "AlloyUnavailable"),
    "instance": ("AlloyPlanVerdict", "AlloyVerdict", "alloy_plan_verdict", "alloy_verdict"),
    "jvm": ("find_jar", "find_jvm"),
    "metamodel": ("metamodel_modules",),
    "worker": ("run_with_timeout",),
}
_MODULE_OF = {name: module for module, names in _WHERE.items() for name in names}

__all__ = sorted(_MODULE_OF)


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'checker.alloy' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"checker.alloy.{module}"), name)
    globals()[name] = value
    return value
