"""The meta-model as modules for the bridge."""
from __future__ import annotations

from importlib.resources import files

from codegen.alloy import DEFAULT_SCOPE, RUN_SCOPE, render_metamodel

MAIN = "reconf.als"


def committed_metamodel() -> str:
    """The meta-model as shipped in the alloy_model package."""
    return (files("alloy_model") / "reconf.als").read_text(encoding="utf-8")


def metamodel_modules(scope: int | None = None, run_scope: int | None = None) -> dict[str, str]:
    """{"reconf.als": text}: the committed meta-model, or re-rendered at other scopes."""
    if scope is None and run_scope is None:
        return {MAIN: committed_metamodel()}

    return {MAIN: render_metamodel(scope or DEFAULT_SCOPE, run_scope or RUN_SCOPE)}
