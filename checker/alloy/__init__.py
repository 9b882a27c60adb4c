"""The Alloy backend: the Alloy 6 jar driven through JPype, reached through one factory.

    from checker.alloy import get_backend
    outcomes = get_backend().run({"main.als": text}, "main.als")

`get_backend()` returns a `Backend` (the protocol every caller uses) or raises
AlloyUnavailable saying what to install.

The names below are loaded on first use (`checker.exports.lazy`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from checker.exports import lazy

if TYPE_CHECKING:
    from checker.alloy.bridge import DEFAULT_SOLVER, AlloyBridge, Backend, CommandOutcome, get_backend
    from checker.alloy.errors import AlloyError, AlloyTimeout, AlloyUnavailable
    from checker.alloy.instance import AlloyPlanVerdict, AlloyVerdict, alloy_plan_verdict, alloy_verdict
    from checker.alloy.jvm import find_jar, find_jvm
    from checker.alloy.metamodel import metamodel_modules
    from checker.alloy.worker import run_with_timeout

__all__, __getattr__ = lazy(__name__, {
    "bridge": ("DEFAULT_SOLVER", "AlloyBridge", "Backend", "CommandOutcome", "get_backend"),
    "errors": ("AlloyError", "AlloyTimeout", "AlloyUnavailable"),
    "instance": ("AlloyPlanVerdict", "AlloyVerdict", "alloy_plan_verdict", "alloy_verdict"),
    "jvm": ("find_jar", "find_jvm"),
    "metamodel": ("metamodel_modules",),
    "worker": ("run_with_timeout",),
})
