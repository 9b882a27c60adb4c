"""The Alloy backend: the Alloy 6 jar driven through JPype, reached through one factory.

    from checker.alloy import get_backend
    outcomes = get_backend().run({"main.als": text}, "main.als")

`get_backend()` returns a `Backend` (the protocol every caller uses) or raises
AlloyUnavailable saying what to install.
"""
from checker.alloy.bridge import DEFAULT_SOLVER, AlloyBridge, Backend, CommandOutcome, get_backend
from checker.alloy.errors import AlloyError, AlloyTimeout, AlloyUnavailable
from checker.alloy.instance import AlloyPlanVerdict, AlloyVerdict, alloy_plan_verdict, alloy_verdict
from checker.alloy.jvm import find_jar, find_jvm
from checker.alloy.metamodel import metamodel_modules
from checker.alloy.worker import run_with_timeout

__all__ = [
    "DEFAULT_SOLVER", "AlloyBridge", "AlloyPlanVerdict", "AlloyVerdict", "alloy_plan_verdict", "alloy_verdict", "AlloyError", "AlloyTimeout", "AlloyUnavailable", "Backend",
    "CommandOutcome", "find_jar", "find_jvm", "get_backend", "metamodel_modules", "run_with_timeout",
]
