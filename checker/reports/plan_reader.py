"""A plan document read back, from reconf or from anywhere else, with where each of its values
is: the steps and the successive configurations `reconf plan verify` judges.

Both formats of docs/executor.md are read: format 2 (the plan's first state in full, `start`,
and per step what it changed, `changes`: `add` and `drop` of `components`, `degraded` and
`roles`) and format 1 (every state in full, `states`). The document may be a whole plan
document (`{"format_version": 2, "plan": {...}, ...}`) or its `plan` alone. Text that is not
JSON, or JSON of another shape, is bad input (RC308); a step or an attachment that names what
the architecture does not declare is too (RC309); both at the file:line:col of the value.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Callable, Optional

import json_source_map

from checker.semantic_model.actions import KINDS, Action, action_from_dict, catalogue, unknown_name
from checker.semantic_model.config import Configuration
from reconf_dsl.diagnostics import DiagnosticError, error
from reconf_dsl.ir import System
from reconf_dsl.span import Span
from reconf_dsl.words import agree, plural

__all__ = ["PlanInput", "read_plan"]

_PARTS = ("components", "degraded", "roles")
_WIDTH = {"components": 0, "degraded": 2, "roles": 3}     # 0: a name, n: a list of n names


@dataclass(frozen=True)
class PlanInput:
    """A plan as its document gives it: each step, each configuration (one more than the
    steps), and where they are: per step its value, per configuration the value that gives
    it (the start, a state of format 1, or the step's change)."""

    file: str
    steps: tuple[Action, ...]
    states: tuple[Configuration, ...]
    step_spans: tuple[Span, ...]
    state_spans: tuple[Span, ...]
    format_version: int
    # the runs of steps the document carries out together: (first, last) from 1, and where each is
    batches: tuple[tuple[int, int], ...] = ()
    batch_spans: tuple[Span, ...] = ()


class _Doc:
    """The parsed JSON and the span of each value by its JSON pointer."""

    def __init__(self, file: str, text: str) -> None:
        self.file = file
        try:
            self.value = json.loads(text)
            self.where = json_source_map.calculate(text)
        except json.JSONDecodeError as e:
            raise DiagnosticError([error("RC308", f"not a plan document: {e.msg}",
                                         Span(file, e.lineno, e.colno, e.lineno, e.colno + 1))]) from None
        except RecursionError:
            raise DiagnosticError([error("RC308", "not a plan document: nested too deep", Span.unknown(file))]) from None

    def span(self, pointer: str) -> Span:
        entry = self.where.get(pointer)
        if entry is None:
            return Span(self.file, 1, 1, 1, 1)
        start, end = entry.value_start, entry.value_end
        return Span(self.file, start.line + 1, start.column + 1, end.line + 1, end.column + 1)

    def bad(self, pointer: str, message: str, code: str = "RC308") -> DiagnosticError:
        return DiagnosticError([error(code, message, self.span(pointer))])

    def get(self, value: Any, pointer: str, key: str, kind: type, what: str, required: bool = True) -> Any:
        """value[key], which must be a `kind`."""
        if key not in value:
            if not required:
                return None
            raise self.bad(pointer, f"{what} lacks `{key}`")
        got = value[key]
        if not isinstance(got, kind) or isinstance(got, bool) and kind is not bool:
            raise self.bad(f"{pointer}/{key}", f"`{key}` of {what} must be {_KIND_WORDS[kind]}")
        return got


_KIND_WORDS = {dict: "an object", list: "a list", str: "a string", int: "a whole number"}


def read_plan(file: str, text: str, system: System) -> PlanInput:
    """The plan in `text` (the content of `file`) on `system`; raises DiagnosticError (RC308,
    RC309) at the value that is wrong."""
    doc = _Doc(file, text)
    top = doc.value
    if not isinstance(top, dict):
        raise doc.bad("", "a plan document is a JSON object")
    root, version = "", 2
    if "plan" in top:
        version = doc.get(top, "", "format_version", int, "the plan document", required=False) or 2
        if version not in (1, 2):
            raise doc.bad("/format_version", f"plan document format {version} is not 1 or 2")
        root = "/plan"
        doc.get(top, "", "plan", dict, "the plan document")
    plan = top["plan"] if root else top
    steps = _steps(doc, plan, root, system)
    if "states" in plan:
        states, spans = _full_states(doc, plan, root, system, len(steps))
        version = 1
    else:
        states, spans = _changed_states(doc, plan, root, system, len(steps))
    batches = _batches(doc, plan, root, len(steps))
    return PlanInput(file, tuple(a for a, _ in steps), states, tuple(doc.span(p) for _, p in steps),
                     tuple(doc.span(p) for p in spans), version, tuple(b for b, _ in batches),
                     tuple(doc.span(p) for _, p in batches))


def _batches(doc: _Doc, plan: dict[str, Any], root: str, steps: int) -> list[tuple[tuple[int, int], str]]:
    """The plan's `batches` (optional): each a [first, last] pair of step numbers, from 1, first < last."""
    out = []
    for i, b in enumerate(doc.get(plan, root, "batches", list, "the plan", required=False) or []):
        here = f"{root}/batches/{i}"
        if not (isinstance(b, list) and len(b) == 2 and all(type(n) is int for n in b)):
            raise doc.bad(here, f"batch {i + 1} must be a pair [first, last] of step numbers")
        if not 1 <= b[0] < b[1] <= steps:
            raise doc.bad(here, f"batch {i + 1} ({b[0]}–{b[1]}) is not a run of at least two of the plan's "
                                f"{steps} steps")
        out.append(((b[0], b[1]), here))
    return out


def _steps(doc: _Doc, plan: dict[str, Any], root: str, system: System) -> list[tuple[Action, str]]:
    fields = {k.name: set(k.fields) for k in KINDS}
    out = []
    for i, step in enumerate(doc.get(plan, root, "steps", list, "the plan")):
        here = f"{root}/steps/{i}"
        if not isinstance(step, dict):
            raise doc.bad(here, f"step {i + 1} must be an object")
        kind = doc.get(step, here, "action", str, f"step {i + 1}")
        if kind not in fields:
            raise doc.bad(f"{here}/action", f"step {i + 1}: unknown action '{kind}' (one of {', '.join(fields)})")
        given = set(step) - {"action"}
        if given != fields[kind]:
            missing, extra = sorted(fields[kind] - given), sorted(given - fields[kind])
            raise doc.bad(here, f"step {i + 1} ({kind}) " + "; ".join(
                ([f"lacks {', '.join(missing)}"] if missing else []) + ([f"has no {', '.join(extra)}"] if extra else [])))
        for name in fields[kind]:
            doc.get(step, here, name, str, f"step {i + 1}")
        action = action_from_dict(step)
        unknown = unknown_name(catalogue(system), action)
        if unknown is not None:
            raise doc.bad(here, f"step {i + 1} ({action.describe()}): {unknown}", "RC309")
        out.append((action, here))
    return out


def _part(doc: _Doc, value: Any, pointer: str, part: str, system: System) -> frozenset[Any]:
    """One part of a configuration (or of a change) as a set, its names checked."""
    items = doc.get(value, pointer, part, list, "a configuration", required=False) or []
    width, out = _WIDTH[part], set()
    known = _known(system)[part]
    for j, item in enumerate(items):
        here = f"{pointer}/{part}/{j}"
        ok = isinstance(item, str) if width == 0 else (
            isinstance(item, list) and len(item) == width and all(isinstance(x, str) for x in item))
        if not ok:
            raise doc.bad(here, f"an entry of `{part}` must be " + (
                "a component's name" if width == 0 else f"a list of {width} names"))
        entry = item if width == 0 else tuple(item)
        unknown = known(entry)
        if unknown:
            raise doc.bad(here, unknown, "RC309")
        out.add(entry)
    return frozenset(out)


def _known(system: System) -> dict[str, Callable[[Any], Optional[str]]]:
    cat = catalogue(system)

    def component(c: str) -> Optional[str]:
        return None if c in cat.comps else f"no component {c} is declared"

    def degraded(f: tuple[str, str]) -> Optional[str]:
        return component(f[0]) or (None if f in cat.funcs else f"{f[0]} has no functionality {f[1]}")

    def role(r: tuple[str, str, str]) -> Optional[str]:
        return (component(r[1]) or (None if r[0] in cat.conns else f"{r[0]} is not a connector of the system")
                or (None if (r[1], r[2]) in cat.ports else f"{r[1]} has no port {r[2]}"))
    return {"components": component, "degraded": degraded, "roles": role}


def _state(doc: _Doc, value: Any, pointer: str, system: System) -> Configuration:
    if not isinstance(value, dict):
        raise doc.bad(pointer, "a configuration is an object of `components`, `degraded` and `roles`")
    extra = sorted(set(value) - set(_PARTS))
    if extra:
        raise doc.bad(pointer, f"a configuration has no {', '.join(extra)}")
    comps, degraded, roles = (_part(doc, value, pointer, p, system) for p in _PARTS)
    return Configuration(comps, degraded, roles)


def _full_states(doc: _Doc, plan: dict[str, Any], root: str, system: System,
                 steps: int) -> tuple[tuple[Configuration, ...], list[str]]:
    states = doc.get(plan, root, "states", list, "the plan")
    if len(states) != steps + 1:
        raise doc.bad(f"{root}/states", f"{plural(steps, 'step')} {agree(steps, 'needs', 'need')} "
                                         f"{plural(steps + 1, 'state')}, not {len(states)}")
    spans = [f"{root}/states/{i}" for i in range(len(states))]
    return tuple(_state(doc, s, p, system) for s, p in zip(states, spans)), spans


def _changed_states(doc: _Doc, plan: dict[str, Any], root: str, system: System,
                    steps: int) -> tuple[tuple[Configuration, ...], list[str]]:
    start = _state(doc, doc.get(plan, root, "start", dict, "the plan (format 2; format 1 has `states`)"),
                   f"{root}/start", system)
    changes = doc.get(plan, root, "changes", list, "the plan")
    if len(changes) != steps:
        raise doc.bad(f"{root}/changes", f"{plural(steps, 'step')} {agree(steps, 'needs', 'need')} "
                                          f"{plural(steps, 'change')}, not {len(changes)}")
    states, spans = [start], [f"{root}/start"]
    for i, change in enumerate(changes):
        here = f"{root}/changes/{i}"
        if not isinstance(change, dict) or set(change) - {"add", "drop"}:
            raise doc.bad(here, f"change {i + 1} must be an object of `add` and `drop`")
        add, drop = (_state(doc, change.get(k, {}), f"{here}/{k}", system) for k in ("add", "drop"))
        s = states[-1]
        states.append(Configuration((s.components - drop.components) | add.components,
                                    (s.degraded - drop.degraded) | add.degraded, (s.roles - drop.roles) | add.roles))
        spans.append(here)
    return tuple(states), spans
