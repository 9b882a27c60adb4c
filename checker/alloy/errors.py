"""Exceptions of the Alloy bridge."""
from __future__ import annotations

from reconf_dsl.span import Span


class AlloyUnavailable(RuntimeError):
    """Java or the Alloy jar cannot be found or started. The message says what to install."""


class AlloyError(Exception):
    """Alloy rejected a module (syntax or type error) or failed while solving.

    `module` is the key of the module in the mapping given to the bridge (e.g.
    "main.als"), `line` and `column` are 1-based positions in it (0 when unknown). For a
    generated instance or plan module, `span` is the DSL declaration the position was
    generated from (see checker.alloy.spans), when there is one.
    """

    def __init__(self, message: str, module: str | None = None, line: int = 0, column: int = 0):

        self.span: Span | None = None
        self.message = message
        self.module = module
        self.line = line
        self.column = column
        where = f"{module}:{line}:{column}: " if module else ""
        super().__init__(f"{where}{message}")


class AlloyTimeout(Exception):
    """A command did not finish within its time limit; its worker process was killed."""

    def __init__(self, label: str | None, seconds: float):
        self.label = label
        self.seconds = seconds
        super().__init__(f"Alloy command {label or '(all)'} did not finish within {seconds:g} s")
