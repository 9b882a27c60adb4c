"""The gate's policy: how much a migration may disrupt, what it must never degrade, which
fault-tolerance mechanisms it must not weaken, and whether a change may fix an unsafe base.

Read from `--policy FILE`, else from the nearest `reconf.toml` or `pyproject.toml` with a
`[tool.reconf]` table (the working directory, then its parents up to the repository root).
In `reconf.toml` the keys may stand at the top level or under `[tool.reconf]`.

    [tool.reconf]
    max-disruption = 4                     # Σ criticality × steps degraded (docs/design.md#disruption)
    max-degraded-seconds = 1.5             # Σ criticality × seconds degraded on the wire, as the plan expects
    never-degrade = ["listener.listen", "control"]   # COMPONENT.FUNCTIONALITY or FUNCTIONALITY
    keep-ftm = true                        # or a list of component names and FTM names ("PBR")
    strategy = "default"                   # planning strategy: default, paper, exhaustive
    allow-unsafe-base = false              # true: a safe head passes although the base is not safe

Every value is checked for its type where it is read (RC505, at the value in the file), and
every name against the architectures once they are loaded (`check_names`, RC508, with the
closest name that exists): a misspelt name would otherwise protect nothing.

FTM coverage (the FTM table of docs/ftm.md#the-library): PBR and LFR cover crash faults, TR covers
transient faults, AD covers crash and transient faults, SEC covers intrusions; a nested FTM
(`SEC(PBR(TR))`) covers the union of what its parts cover. A component covers a fault when it
declares it (`faults crash`) and its FTM covers it. An FTM is weakened when a fault covered in
the base architecture is no longer covered by the FTM of the same component in the new one
(a component that is removed weakens nothing).
"""
from __future__ import annotations

import difflib
import os
import re
import tomllib
from dataclasses import dataclass, field, replace
from typing import Any, Optional

from checker.ftm.library import LIBRARY, layers
from checker.planning import STRATEGIES
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Related, error
from reconf_dsl.ir import Component, FtmExpr, System
from reconf_dsl.loader import Sources, display_path, read_source
from reconf_dsl.span import Span

# What each FTM covers: the library's Table I, read once (never written out again here).
COVERAGE: dict[str, frozenset[str]] = {name: m.covers for name, m in LIBRARY.items()}
KEYS = ("max-disruption", "max-degraded-seconds", "never-degrade", "keep-ftm", "strategy", "allow-unsafe-base")
TABLE = "tool.reconf"


def ftm_names(expr: Optional[FtmExpr]) -> list[str]:
    """The mechanisms of an FTM expression, outermost first; [] for none."""
    return layers(expr) if expr is not None else []


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
    allow_unsafe_base: bool = False
    # key → the span of each entry of its list, in order (for never-degrade and keep-ftm)
    entry_spans: dict[str, tuple[Span, ...]] = field(default_factory=dict, compare=False)
    origin: str = ""                        # the git revision it was read from; "" for a file here
    max_degraded_seconds: Optional[float] = None

    @property
    def where(self) -> str:
        if not self.source:
            return "the default policy"
        table = " [tool.reconf]" if os.path.basename(self.source) == "pyproject.toml" else ""
        at = f" at {self.origin}" if self.origin else ""
        return f"the policy in {self.source}{table}{at}"

    def span(self, key: str) -> Span:
        return self.spans.get(key) or Span(self.source or "<policy>", 1, 1, 1, 1)

    def entry_span(self, key: str, index: int) -> Span:
        spans = self.entry_spans.get(key, ())
        return spans[index] if index < len(spans) else self.span(key)

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
                "max-degraded-seconds": self.max_degraded_seconds,
                "never-degrade": list(self.never_degrade),
                "keep-ftm": True if "*" in self.keep_ftm else list(self.keep_ftm), "strategy": self.strategy,
                "allow-unsafe-base": self.allow_unsafe_base}


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


# ---------------------------------------------------------------- where keys and values stand in the text

@dataclass
class _Located:
    """A key of the policy's table as written: its line, the whole value, and each entry of a list."""

    line: Span
    value: Span
    entries: list[Span] = field(default_factory=list)


_KEY = re.compile(r"""\s*("(?:[^"\\]|\\.)*"|'[^']*'|[A-Za-z0-9_.-]+)\s*=[ \t]*""")
_BARE = re.compile(r"[A-Za-z0-9_+.:-]+")


def _header(line: str) -> Optional[str]:
    """The table a `[table]` or `[[array]]` header line opens, as dotted bare names; None for other lines."""
    s = line.split("#", 1)[0].strip()
    if not (s.startswith("[") and s.endswith("]")):
        return None
    name = s.strip("[]")
    return ".".join(part.strip().strip("\"'") for part in name.split("."))


def locate(text: str, shown: str, tables: tuple[str, ...]) -> dict[str, _Located]:
    """Each key of `tables` ("" for the top level) as written in the TOML `text`; keys are
    given with `-` for `_`. A small scanner, enough for positions: tomllib reads the values."""
    lines = text.split("\n")
    out: dict[str, _Located] = {}
    table = ""
    i = 0
    while i < len(lines):
        line = lines[i]
        head = _header(line)
        if head is not None:
            table = head
            i += 1
            continue
        m = _KEY.match(line)
        if not m:
            i += 1
            continue
        key = m.group(1).strip("\"'")
        full = f"{table}.{key}" if table else key
        name = next((full[len(t) + 1:] if t else full for t in tables
                     if (full.startswith(t + ".") if t else "." not in full)), None)
        start = Span(shown, i + 1, len(line) - len(line.lstrip()) + 1, i + 1, len(line.rstrip()) + 1)
        end_line, entries, value = _scan_value(lines, i, m.end(), shown)
        if name is not None:
            out.setdefault(name.replace("_", "-"), _Located(start, value, entries))
        i = end_line + 1
    return out


def _scan_value(lines: list[str], row: int, col: int, shown: str) -> tuple[int, list[Span], Span]:
    """From a value's first character: the last line it uses, the spans of the entries at depth 1
    (a list's items), and the span of the whole value."""
    depth = 0
    entries: list[Span] = []
    first: Optional[tuple[int, int]] = None
    last = (row, col)
    r, c = row, col
    while r < len(lines):
        line = lines[r]
        while c < len(line):
            ch = line[c]
            if ch in " \t,":
                c += 1
                continue
            if ch == "#":
                break
            begin = (r, c)
            if ch in "[{":
                depth += 1
                c += 1
            elif ch in "]}":
                depth -= 1
                c += 1
            elif ch in "\"'":
                triple = line.startswith(ch * 3, c)
                r, c = _end_of_string(lines, r, c, ch, triple)
                line = lines[r] if r < len(lines) else ""
            else:
                m = _BARE.match(line, c)
                c = m.end() if m else c + 1
            if first is None:
                first = begin
            last = (r, c)
            if ch not in "[]{}" and depth == 1:
                entries.append(Span(shown, begin[0] + 1, begin[1] + 1, r + 1, c + 1))
            if depth <= 0 and ch not in "[{":
                return r, entries, _span(shown, first, last)
        if depth <= 0 and first is not None:
            return r, entries, _span(shown, first, last)
        r, c = r + 1, 0
    return len(lines) - 1, entries, _span(shown, first or (row, col), last)


def _end_of_string(lines: list[str], r: int, c: int, quote: str, triple: bool) -> tuple[int, int]:
    """The position just after the string that starts at (r, c)."""
    c += 3 if triple else 1
    while r < len(lines):
        line = lines[r]
        while c < len(line):
            if quote == '"' and line[c] == "\\":
                c += 2
                continue
            if triple and line.startswith(quote * 3, c):
                return r, c + 3
            if not triple and line[c] == quote:
                return r, c + 1
            c += 1
        if not triple:
            return r, c
        r, c = r + 1, 0
    return len(lines) - 1, len(lines[-1]) if lines else 0


def _span(shown: str, first: tuple[int, int], last: tuple[int, int]) -> Span:
    return Span(shown, first[0] + 1, first[1] + 1, last[0] + 1, last[1] + 1)


# ---------------------------------------------------------------- reading the policy

def load_policy(path: Optional[str] = None, shown: Optional[str] = None, origin: str = "",
                sources: Optional[Sources] = None) -> Policy:
    """`path`, or the policy found from the working directory, or the default (no limits).
    `shown` names the file in messages when it is not `path`, and `origin` the git revision
    it was read from; its text goes to `sources`, for snippets."""
    explicit = path is not None
    path = path or find_policy_file()
    if path is None:
        return Policy()
    shown = shown or display_path(path)
    if not os.path.exists(path):
        raise DiagnosticError([error("RC505", f"no such policy file: {shown}", Span(shown, 1, 1, 1, 1))])
    try:
        text = read_source(path, Sources())             # bounded as an architecture is: /dev/zero is refused
        if sources is not None:
            sources.texts[shown] = text
        data = tomllib.loads(text)
    except DiagnosticError as e:
        d = e.diagnostics[0]
        raise DiagnosticError([error("RC505", f"cannot read the policy {shown}: {d.message}", Span(shown, 1, 1, 1, 1),
                                     notes=d.notes)]) from None
    except tomllib.TOMLDecodeError as e:
        line = int(m.group(1)) if (m := re.search(r"line (\d+)", str(e))) else 1
        col = int(m.group(1)) if (m := re.search(r"column (\d+)", str(e))) else 1
        raise DiagnosticError([error("RC505", f"the policy {shown} is not valid TOML: {e}",
                                     Span(shown, line, col, line, col + 1))]) from None
    tool = data.get("tool", {})
    reconf = tool.get("reconf") if isinstance(tool, dict) else None
    pyproject = os.path.basename(path) == "pyproject.toml"
    if pyproject:
        if reconf is None and explicit:
            raise DiagnosticError([error("RC505", f"{shown} has no [tool.reconf] table", Span(shown, 1, 1, 1, 1))])
        policy = parse_policy(reconf if isinstance(reconf, dict) else {}, shown, text, (TABLE,))
        return replace(policy, origin=origin)
    # reconf.toml: the keys at the top level and under [tool.reconf] together
    table = {k: v for k, v in data.items() if k != "tool"}
    errors = []
    if isinstance(reconf, dict):
        where = locate(text, shown, (TABLE,))
        for k, v in reconf.items():
            if k in table:
                errors.append(error("RC505", f"'{k}' is given twice: at the top level and under [tool.reconf]",
                                    where[k.replace("_", "-")].line if k.replace("_", "-") in where
                                    else Span(shown, 1, 1, 1, 1)))
            table[k] = v
    if errors:
        raise DiagnosticError(errors)
    return replace(parse_policy(table, shown, text, ("", TABLE)), origin=origin)


def _describe(value: Any) -> str:
    """A TOML value as a person would say it in a message."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'the string "{value}"'
    if isinstance(value, (int, float)):
        return f"the number {value}"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a table"
    return f"a {type(value).__name__}"


BOOLEAN_WORDS = {"yes": "true", "no": "false", "true": "true", "false": "false", "on": "true", "off": "false",
                 "y": "true", "n": "false", "1": "true", "0": "false"}


def parse_policy(table: dict[str, Any], shown: str, text: str = "", tables: tuple[str, ...] = ("", TABLE)) -> Policy:
    """The policy of a TOML table (keys with `-` or `_`), every value checked for its type (RC505)."""
    r = _PolicyReader(locate(text, shown, tables), Span(shown, 1, 1, 1, 1))
    r.read_keys(table)
    md = r.max_disruption()
    ms = r.max_degraded_seconds()
    nd, nd_spans = r.never_degrade()
    kf, kf_spans = r.names("keep-ftm", "component and FTM names", True)
    strategy = r.strategy()
    unsafe = r.allow_unsafe_base()
    if r.errors:
        raise DiagnosticError(sorted(r.errors, key=lambda d: (d.span.line, d.span.col)))
    return Policy(md, tuple(nd), tuple(kf), str(strategy), shown, r.spans, unsafe is True,
                  {"never-degrade": tuple(nd_spans), "keep-ftm": tuple(kf_spans)}, max_degraded_seconds=ms)


@dataclass
class _PolicyReader:
    """The checks of one policy table, each reporting into `errors` at the span of what it checks."""

    where: dict[str, _Located]  # what `locate` found: each key's line, value and list entries
    fallback: Span              # where a key the text does not show is reported
    values: dict[str, Any] = field(default_factory=dict)
    errors: list[Diagnostic] = field(default_factory=list)
    spans: dict[str, Span] = field(init=False)     # each key's line

    def __post_init__(self) -> None:
        self.spans = {k: self.where[k].line if k in self.where else self.fallback for k in KEYS}

    def value_span(self, key: str) -> Span:
        return self.where[key].value if key in self.where else self.spans[key]

    def entry(self, key: str, i: int) -> Span:
        located = self.where.get(key)
        return located.entries[i] if located is not None and i < len(located.entries) else self.value_span(key)

    def read_keys(self, table: dict[str, Any]) -> None:
        """Keep the values of known keys (`_` read as `-`); report the others."""
        for raw_key, value in table.items():
            key = raw_key.replace("_", "-")
            if key not in KEYS:
                close = difflib.get_close_matches(key, KEYS, n=1)
                self.errors.append(error("RC505", f"unknown policy key '{raw_key}'"
                                         + (f"; did you mean '{close[0]}'?" if close else ""),
                                         self.where[key].line if key in self.where else self.fallback,
                                         notes=("known keys: " + ", ".join(KEYS),)))
                continue
            self.values[key] = value

    def max_disruption(self) -> Optional[int]:
        md = self.values.get("max-disruption")
        if md is not None and (isinstance(md, bool) or not isinstance(md, int) or md < 0):
            notes = (f"write max-disruption = {md.strip()} (no quotes)",) if isinstance(md, str) and \
                md.strip().isdigit() else ()
            self.errors.append(error("RC505", f"max-disruption must be a whole number ≥ 0, not {_describe(md)}",
                                     self.value_span("max-disruption"), notes=notes))
            return None
        return md

    def max_degraded_seconds(self) -> Optional[float]:
        ms = self.values.get("max-degraded-seconds")
        if ms is not None and (isinstance(ms, bool) or not isinstance(ms, (int, float)) or not 0 <= ms < float("inf")):
            self.errors.append(error("RC505", f"max-degraded-seconds must be a number of seconds ≥ 0, not {_describe(ms)}",
                                     self.value_span("max-degraded-seconds")))
            return None
        return None if ms is None else float(ms)

    def names(self, key: str, what: str, allow_bool: bool) -> tuple[list[str], list[Span]]:
        """A list of names (or, with `allow_bool`, true for every one and false for none)."""
        v = self.values.get(key)
        if v is None or v is False and allow_bool:
            return [], []
        if v is True and allow_bool:
            return ["*"], []
        if not isinstance(v, list):
            shape = "true, false, or a list of " if allow_bool else "a list of "
            self.errors.append(error("RC505", f"{key} must be {shape}{what}, not {_describe(v)}",
                                     self.value_span(key), notes=_names_notes(key, v, allow_bool)))
            return [], []
        good, good_spans = [], []
        for i, x in enumerate(v):
            if not isinstance(x, str):
                self.errors.append(error("RC505", f"each entry of {key} must be a name in quotes, "
                                         f"not {_describe(x)}", self.entry(key, i)))
            elif not x.strip():
                self.errors.append(error("RC505", f"an empty name in {key}", self.entry(key, i)))
            else:
                good.append(x)
                good_spans.append(self.entry(key, i))
        return good, good_spans

    def never_degrade(self) -> tuple[list[str], list[Span]]:
        nd, nd_spans = self.names("never-degrade", "COMPONENT.FUNCTIONALITY or FUNCTIONALITY names", False)
        for x, s in zip(nd, nd_spans):
            if x.count(".") > 1 or x.startswith(".") or x.endswith("."):
                self.errors.append(error("RC505", f"'{x}' in never-degrade is neither COMPONENT.FUNCTIONALITY "
                                         "nor FUNCTIONALITY", s))
        return nd, nd_spans

    def strategy(self) -> Any:
        strategy = self.values.get("strategy", "default")
        if strategy not in STRATEGIES or not isinstance(strategy, str):
            close = difflib.get_close_matches(strategy, STRATEGIES, n=1) if isinstance(strategy, str) else []
            self.errors.append(error("RC505", f"strategy must be one of {', '.join(STRATEGIES)} (in quotes), "
                                     f"not {_describe(strategy)}" + (f"; did you mean '{close[0]}'?" if close else ""),
                                     self.value_span("strategy")))
        return strategy

    def allow_unsafe_base(self) -> Any:
        unsafe = self.values.get("allow-unsafe-base", False)
        if not isinstance(unsafe, bool):
            notes = (f"write allow-unsafe-base = {BOOLEAN_WORDS[unsafe.strip().lower()]} (no quotes)",) \
                if isinstance(unsafe, str) and unsafe.strip().lower() in BOOLEAN_WORDS else ()
            self.errors.append(error("RC505", f"allow-unsafe-base must be true or false, not {_describe(unsafe)}",
                                     self.value_span("allow-unsafe-base"), notes=notes))
        return unsafe


def _names_notes(key: str, v: Any, allow_bool: bool) -> tuple[str, ...]:
    """How to write a list of names given as something else."""
    if isinstance(v, str) and allow_bool and v.strip().lower() in BOOLEAN_WORDS:
        return (f"write {key} = {BOOLEAN_WORDS[v.strip().lower()]} (no quotes)",)
    if isinstance(v, str):
        return (f'write {key} = ["{v}"] for a list of one name',)
    if isinstance(v, bool):
        return (f'write {key} = [] for none',)
    return ()


# ---------------------------------------------------------------- names against the architectures

def _suggest(name: str, candidates: list[str]) -> tuple[str, ...]:
    close = difflib.get_close_matches(name, candidates, n=1, cutoff=0.6)
    return (f"did you mean '{close[0]}'?",) if close else ()


def check_names(policy: Policy, old: System, new: System) -> list[Diagnostic]:
    """RC508 for every name of the policy that names nothing: a never-degrade entry that is no
    functionality (of that component) in the head or the base, a keep-ftm entry that is neither
    a component of either nor an FTM. The base counts because a migration degrades its
    components too, and keep-ftm protects what the base covers."""
    comps: dict[str, Component] = {}
    for s in (old, new):
        for c in s.components:
            comps.setdefault(c.name, c)
    funcs: dict[str, set[str]] = {}
    for s in (new, old):
        for c in s.components:
            funcs.setdefault(c.name, set()).update(f.name for f in c.functionalities)
    all_funcs = sorted({f for fs in funcs.values() for f in fs})
    qualified = sorted(f"{c}.{f}" for c, fs in funcs.items() for f in fs)
    both = (f"the head ({new.name}) or the base ({old.name})" if new.name != old.name else
            f"{new.name} (head or base)")
    out: list[Diagnostic] = []
    rel = (Related(new.span, f"the head: {new.name}"), Related(old.span, f"the base: {old.name}"))
    for i, entry in enumerate(policy.never_degrade):
        span = policy.entry_span("never-degrade", i)
        said = f"never-degrade in {policy.where} names '{entry}'"
        comp, dot, func = entry.rpartition(".")
        if not dot:
            if entry not in all_funcs:
                out.append(error("RC508", f"{said}, which is no functionality of any component in {both}: it "
                                 "would protect nothing", span, related=rel,
                                 notes=_suggest(entry, all_funcs + qualified)))
        elif comp not in funcs:
            out.append(error("RC508", f"{said}, but {both} has no component '{comp}'", span, related=rel,
                             notes=_suggest(entry, qualified) or _suggest(comp, sorted(funcs))))
        elif func not in funcs[comp]:
            have = ", ".join(sorted(funcs[comp])) or "none"
            out.append(error("RC508", f"{said}, but {comp} has no functionality '{func}' in {both}", span,
                             related=rel, notes=_suggest(func, sorted(funcs[comp])) + (f"{comp} has: {have}",)))
    for i, entry in enumerate(policy.keep_ftm):
        if entry == "*" or entry in comps or entry in COVERAGE:
            continue
        out.append(error("RC508", f"keep-ftm in {policy.where} names '{entry}', which is neither a component of "
                         f"{both} nor an FTM ({', '.join(COVERAGE)}): it would protect nothing",
                         policy.entry_span("keep-ftm", i), related=rel,
                         notes=_suggest(entry, sorted(comps) + list(COVERAGE))))
    return out
