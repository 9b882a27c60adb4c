"""The gate's policy: how much a migration may disrupt, what it must never degrade, which
fault-tolerance mechanisms it must not weaken.

Read from `--policy FILE`, else from the nearest `reconf.toml` or `pyproject.toml` with a
`[tool.reconf]` table (the working directory, then its parents up to the repository root).
In `reconf.toml` the keys may stand at the top level or under `[tool.reconf]`.

    [tool.reconf]
    max-disruption = 4                     # Σ criticality × steps degraded (DESIGN.md §7)
    never-degrade = ["listener.listen", "control"]   # COMPONENT.FUNCTIONALITY or FUNCTIONALITY
    keep-ftm = true                        # or a list of component names and FTM names ("PBR")
    strategy = "default"                   # planning strategy: default, paper, exhaustive

FTM coverage (from the FTM table of DESIGN.md §6): PBR and LFR cover crash faults, TR covers
transient faults, AD covers crash and transient faults, SEC covers intrusions; a nested FTM
(`SEC(PBR(TR))`) covers the union of what its parts cover. A component covers a fault when it
declares it (`faults crash`) and its FTM covers it. An FTM is weakened when a fault covered in
the base architecture is no longer covered by the FTM of the same component in the new one
(a component that is removed weakens nothing).
"""
from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass, field
from typing import Any, Optional

from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, error
from reconf_dsl.ir import Component, FtmExpr
from reconf_dsl.loader import display_path
from reconf_dsl.span import Span

COVERAGE: dict[str, frozenset[str]] = {
    "PBR": frozenset({"crash"}),
    "LFR": frozenset({"crash"}),
    "TR": frozenset({"transient"}),
    "AD": frozenset({"crash", "transient"}),
    "SEC": frozenset({"intrusion"}),
}
KEYS = ("max-disruption", "never-degrade", "keep-ftm", "strategy")
STRATEGIES = ("default", "paper", "exhaustive")


def ftm_names(expr: Optional[FtmExpr]) -> list[str]:
    names = []
    while expr is not None:
        names.append(expr.name)
        expr = expr.inner
    return names


def coverage(expr: Optional[FtmExpr]) -> frozenset[str]:
    """The faults an FTM expression covers: the union over its nesting."""
    out: frozenset[str] = frozenset()
    for name in ftm_names(expr):
        out |= COVERAGE.get(name, frozenset())
    return out


def covered(c: Component) -> frozenset[str]:
    """The faults `c` declares that its FTM covers."""
    return frozenset(c.faults) & coverage(c.ftm.expr if c.ftm else None)


@dataclass(frozen=True)
class Policy:
    max_disruption: Optional[int] = None
    never_degrade: tuple[str, ...] = ()
    keep_ftm: tuple[str, ...] = ()          # "*" for every component
    strategy: str = "default"
    source: str = ""                        # the file it came from; "" for the built-in default
    spans: dict[str, Span] = field(default_factory=dict, compare=False)

    @property
    def where(self) -> str:
        if not self.source:
            return "the default policy"
        table = " [tool.reconf]" if os.path.basename(self.source) == "pyproject.toml" else ""
        return f"the policy in {self.source}{table}"

    def span(self, key: str) -> Span:
        return self.spans.get(key) or Span(self.source or "<policy>", 1, 1, 1, 1)

    def forbids_degrading(self, component: str, functionality: str) -> Optional[str]:
        """The never-degrade entry that protects this functionality, if any."""
        for entry in self.never_degrade:
            if entry in (f"{component}.{functionality}", functionality):
                return entry
        return None

    def protects_ftm(self, component: str, ftms: list[str]) -> bool:
        return "*" in self.keep_ftm or component in self.keep_ftm or any(f in self.keep_ftm for f in ftms)

    def to_json(self) -> dict[str, Any]:
        return {"source": self.source or None, "max-disruption": self.max_disruption,
                "never-degrade": list(self.never_degrade),
                "keep-ftm": True if "*" in self.keep_ftm else list(self.keep_ftm), "strategy": self.strategy}


def find_policy_file(start: Optional[str] = None) -> Optional[str]:
    """The nearest reconf.toml, or pyproject.toml with [tool.reconf], from `start` up to the repository root."""
    here = os.path.abspath(start or os.getcwd())
    while True:
        candidate = os.path.join(here, "reconf.toml")
        if os.path.isfile(candidate):
            return candidate
        candidate = os.path.join(here, "pyproject.toml")
        if os.path.isfile(candidate):
            try:
                with open(candidate, "rb") as f:
                    if "reconf" in tomllib.load(f).get("tool", {}):
                        return candidate
            except (OSError, tomllib.TOMLDecodeError):
                pass
        parent = os.path.dirname(here)
        if os.path.exists(os.path.join(here, ".git")) or parent == here:
            return None
        here = parent


def _key_span(shown: str, text: str, key: str) -> Span:
    pattern = re.compile(r"^\s*[\"']?" + re.escape(key).replace(r"\-", "[-_]") + r"[\"']?\s*=")
    for i, line in enumerate(text.split("\n"), 1):
        if pattern.match(line):
            return Span(shown, i, len(line) - len(line.lstrip()) + 1, i, len(line.rstrip()) + 1)
    return Span(shown, 1, 1, 1, 1)


def load_policy(path: Optional[str] = None) -> Policy:
    """`path`, or the policy found from the working directory, or the default (no limits)."""
    explicit = path is not None
    path = path or find_policy_file()
    if path is None:
        return Policy()
    shown = display_path(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
        text = raw.decode("utf-8")
        data = tomllib.loads(text)
    except FileNotFoundError:
        raise DiagnosticError([error("RC505", f"no such policy file: {shown}", Span(shown, 1, 1, 1, 1))]) from None
    except (OSError, UnicodeDecodeError) as e:
        raise DiagnosticError([error("RC505", f"cannot read the policy {shown}: {e}", Span(shown, 1, 1, 1, 1))]) \
            from None
    except tomllib.TOMLDecodeError as e:
        line = int(m.group(1)) if (m := re.search(r"line (\d+)", str(e))) else 1
        raise DiagnosticError([error("RC505", f"the policy {shown} is not valid TOML: {e}",
                                     Span(shown, line, 1, line, 1))]) from None
    table: dict[str, Any] = data.get("tool", {}).get("reconf", {})
    if not table and os.path.basename(path) != "pyproject.toml":
        table = {k: v for k, v in data.items() if k != "tool"}
    elif not table and explicit and "reconf" not in data.get("tool", {}):
        raise DiagnosticError([error("RC505", f"{shown} has no [tool.reconf] table", Span(shown, 1, 1, 1, 1))])
    return parse_policy(table, shown, text)


def parse_policy(table: dict[str, Any], shown: str, text: str = "") -> Policy:
    errors: list[Diagnostic] = []
    spans = {k: _key_span(shown, text, k) for k in KEYS}
    values: dict[str, Any] = {}
    for raw_key, value in table.items():
        key = raw_key.replace("_", "-")
        if key not in KEYS:
            errors.append(error("RC505", f"unknown policy key '{raw_key}'", _key_span(shown, text, raw_key),
                                notes=("known keys: " + ", ".join(KEYS),)))
            continue
        values[key] = value
    md = values.get("max-disruption")
    if md is not None and (isinstance(md, bool) or not isinstance(md, int) or md < 0):
        errors.append(error("RC505", "max-disruption must be a whole number ≥ 0", spans["max-disruption"]))
    nd = values.get("never-degrade", [])
    if isinstance(nd, str):
        nd = [nd]
    if not isinstance(nd, list) or not all(isinstance(x, str) for x in nd):
        errors.append(error("RC505", "never-degrade must be a list of COMPONENT.FUNCTIONALITY or FUNCTIONALITY names",
                            spans["never-degrade"]))
        nd = []
    kf = values.get("keep-ftm", [])
    if kf is True:
        kf = ["*"]
    elif kf is False:
        kf = []
    elif isinstance(kf, str):
        kf = [kf]
    if not isinstance(kf, list) or not all(isinstance(x, str) for x in kf):
        errors.append(error("RC505", "keep-ftm must be true, false, or a list of component and FTM names",
                            spans["keep-ftm"]))
        kf = []
    strategy = values.get("strategy", "default")
    if strategy not in STRATEGIES:
        errors.append(error("RC505", f"unknown strategy {strategy!r}", spans["strategy"],
                            notes=("known: " + ", ".join(STRATEGIES),)))
    if errors:
        raise DiagnosticError(errors)
    return Policy(md if isinstance(md, int) else None, tuple(nd), tuple(kf), str(strategy), shown, spans)
