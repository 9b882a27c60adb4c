"""Render Alloy text from the templates in codegen/templates/alloy/.

The meta-model (`alloy_model/reconf.als`) and the instance modules share one set of
semantic definitions, the macros of `semantics.j2`; a `StateAccess` says how those
definitions reach a configuration.

    python -m codegen.alloy --regenerate   # rewrite alloy_model/reconf.als
    python -m codegen.alloy --check        # exit 1 if it is out of date
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import jinja2

TEMPLATES = Path(__file__).parent / "templates" / "alloy"
METAMODEL_PATH = Path(__file__).resolve().parent.parent / "alloy_model" / "reconf.als"
DEFAULT_SCOPE = 5
RUN_SCOPE = 3


@dataclass(frozen=True)
class StateAccess:
    """How the shared semantics reaches a configuration.

    With `var` (e.g. "s") and `sig` (e.g. "System"), every definition takes the
    configuration as its first parameter and configuration relations are fields of it.
    With `var=None`, the configuration is fixed and its relations are constants named by
    `prefix + name` (`comps`, `degraded`, `roles`).
    """

    var: str | None = "s"
    sig: str = "System"
    prefix: str = ""
    materialized: bool = False
    sat: str = "sat"

    def head(self, name: str, params: str) -> str:
        decls = [p for p in ((f"{self.var}: {self.sig}" if self.var else ""), params) if p]
        return f"{name}[{', '.join(decls)}]" if decls else name

    def call(self, name: str, args: str) -> str:
        parts = [p for p in (self.var or "", args) if p]
        return f"{name}[{', '.join(parts)}]" if parts else name

    def rel(self, name: str) -> str:
        return f"({self.var}.{name})" if self.var else f"{self.prefix}{name}"

    def cached(self, field: str, definition: str) -> str:
        """A derived set of the configuration: the stored relation `field` when
        materialized, else a call of its definition."""
        return self.rel(field) if self.materialized else self.call(definition, "")


# The meta-model: configurations are System atoms; the satisfaction relation and the
# satisfied connectors/inputs are relations fixed by facts.
META_STATE = StateAccess("s", "System", materialized=True, sat="(Sem.sat)")
# An instance module: one fixed configuration given by constants.
FIXED_STATE = StateAccess(None, sat="sat")


def environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=False,
        lstrip_blocks=False,
        autoescape=False,
    )


def render_metamodel(scope: int = DEFAULT_SCOPE, run_scope: int = RUN_SCOPE) -> str:
    """The meta-model text, with every check at `scope` and every run at `run_scope`."""
    template = environment().get_template("reconf.als.j2")
    return template.render(st=META_STATE, scope=scope, run_scope=run_scope)


def render_semantics(st: StateAccess = FIXED_STATE) -> str:
    """The shared definitions alone, for an instance module."""
    macros = environment().get_template("semantics.j2").module
    return str(macros.semantics(st))  # type: ignore[attr-defined]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m codegen.alloy")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--regenerate", action="store_true", help="rewrite alloy_model/reconf.als")
    group.add_argument("--check", action="store_true", help="fail if reconf.als is out of date")
    args = parser.parse_args(argv)
    text = render_metamodel()
    if args.regenerate:
        METAMODEL_PATH.write_text(text, encoding="utf-8")
        print(f"wrote {METAMODEL_PATH}")
        return 0
    if METAMODEL_PATH.read_text(encoding="utf-8") != text:
        print(f"{METAMODEL_PATH} is out of date: run python -m codegen.alloy --regenerate")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
