"""Diagnostic codes as SARIF rules: each code's stable name and meaning, from the one
registry of codes (`reconf_dsl.codes`)."""
from __future__ import annotations

from reconf_dsl.codes import BY_CODE


def rule(code: str) -> tuple[str, str]:
    """(name, description) of a code. Every code reconf reports is registered (a test holds
    it so); anything else is named after itself."""
    known = BY_CODE.get(code)
    return (known.name, known.meaning) if known is not None else (code.lower(), "reconf finding")
