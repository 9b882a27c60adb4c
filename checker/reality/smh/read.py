"""Reading an SMH model file (ROS 2 system_modes) with the position of everything in it.

The format is a ROS 2 parameter file (docs/modes.md#the-smh-format): each part is
`NAME: {ros__parameters: {type: system|node, modes: {__DEFAULT__: …, MODE: …}}}`; a node's mode
sets parameters under `ros__parameters`, a system's maps each part to `state[.MODE]`. A mapping
without `ros__parameters` is a namespace (`left: {manipulator: …}` is the part `left/manipulator`).
What is not YAML is RC621, what is YAML but not such a model RC622, both with file:line:col."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from checker.reality.smh import DEFAULT, STATES
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, error, warning
from reconf_dsl.span import Span

__all__ = ["Param", "NodeMode", "PartMode", "SystemMode", "Part", "Model", "read_model"]

MAX_DEPTH = 64            # nested mappings of one parameter
MAX_VALUES = 100_000      # parameters and part modes in one file (aliases may repeat a subtree)


@dataclass(frozen=True)
class Param:
    name: str
    value: str            # as written
    span: Span


@dataclass(frozen=True)
class NodeMode:
    name: str
    params: tuple[Param, ...]
    span: Span


@dataclass(frozen=True)
class PartMode:
    part: str
    state: str            # a lifecycle state: active, inactive, …
    mode: Optional[str]   # the part's mode when active (None: its __DEFAULT__)
    span: Span


@dataclass(frozen=True)
class SystemMode:
    name: str
    parts: tuple[PartMode, ...]
    span: Span


@dataclass(frozen=True)
class Part:
    name: str
    kind: str             # "system" or "node"
    node_modes: tuple[NodeMode, ...] = ()
    system_modes: tuple[SystemMode, ...] = ()
    rules: tuple[str, ...] = ()
    span: Span = Span.unknown()


@dataclass
class Model:
    file: str
    parts: list[Part] = field(default_factory=list)
    warnings: list[Diagnostic] = field(default_factory=list)


def read_model(text: str, file: str) -> Model:
    """The parts of the model in `text` (read from `file`); DiagnosticError when it is none."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = _span(file, mark, mark) if mark is not None else Span(file, 1, 1, 1, 1)
        raise DiagnosticError([error("RC621", f"not YAML: {e.problem or e.context}", where)]) from None
    except (yaml.YAMLError, RecursionError) as e:
        why = "nested too deeply" if isinstance(e, RecursionError) else str(e)
        raise DiagnosticError([error("RC621", f"not YAML: {why}", Span(file, 1, 1, 1, 1))]) from None
    reader = _Reader(file)
    if root is None:
        raise DiagnosticError([_not_a_model(Span(file, 1, 1, 1, 1), "the file holds no YAML document")])
    reader.entries(root, "")
    if not reader.model.parts:
        raise DiagnosticError([_not_a_model(_node_span(file, root), "no entry has `ros__parameters: {type: "
                                                                    "system}` or `{type: node}`")])
    return reader.model


def _not_a_model(where: Span, why: str) -> Diagnostic:
    return error("RC622", f"not an SMH model file: {why}", where,
                 notes=("the format: docs/modes.md#the-smh-format",))


def _span(file: str, start: yaml.Mark, end: yaml.Mark) -> Span:
    return Span(file, start.line + 1, start.column + 1, end.line + 1, end.column + 1)


def _node_span(file: str, node: Node) -> Span:
    return _span(file, node.start_mark, node.end_mark)


class _Reader:
    def __init__(self, file: str) -> None:
        self.file = file
        self.model = Model(file)
        self.values = 0

    def fail(self, node: Node, why: str) -> DiagnosticError:
        return DiagnosticError([_not_a_model(_node_span(self.file, node), why)])

    def mapping(self, node: Node, what: str) -> list[tuple[str, Node, Node]]:
        """The entries of a mapping node as (key, key node, value node); keys are scalars."""
        if not isinstance(node, MappingNode):
            raise self.fail(node, f"{what} must be a mapping")
        out = []
        for k, v in node.value:
            if not isinstance(k, ScalarNode):
                raise self.fail(k, f"a key of {what} must be a name")
            out.append((k.value, k, v))
        return out

    def entries(self, node: Node, prefix: str) -> None:
        """Top-level entries: parts, or namespaces holding parts."""
        for name, key, value in self.mapping(node, "the file (parts by name)" if not prefix else prefix):
            full = prefix + name.lstrip("/")
            items = dict((k, v) for k, _, v in self.mapping(value, f"the entry {full}"))
            if "ros__parameters" not in items:
                if prefix.count("/") >= MAX_DEPTH:
                    raise self.fail(key, "namespaces nested too deeply")
                self.entries(value, full + "/")
                continue
            self.part(full, key, items["ros__parameters"])

    def part(self, name: str, key: Node, params: Node) -> None:
        items = {k: (kn, v) for k, kn, v in self.mapping(params, f"{name}'s ros__parameters")}
        where = _node_span(self.file, key)
        if "type" not in items:
            self.model.warnings.append(warning("RC624", f"{name} is not an SMH part (no `type`): left out", where))
            return
        kind_node = items["type"][1]
        kind = kind_node.value if isinstance(kind_node, ScalarNode) else ""
        if kind not in ("system", "node"):
            raise self.fail(kind_node, f"{name}'s type must be `system` or `node`")
        if "modes" not in items:
            raise self.fail(key, f"{name} has no modes (SMH needs at least {DEFAULT})")
        modes = self.mapping(items["modes"][1], f"{name}'s modes")
        if not modes or modes[0][0] != DEFAULT:
            at = modes[0][1] if modes else items["modes"][0]
            raise self.fail(at, f"{name}'s first mode must be {DEFAULT} (SMH reads the others as changes to it)")
        rules = tuple(r for r, _, _ in self.mapping(items["rules"][1], f"{name}'s rules")) if "rules" in items else ()
        if kind == "node":
            nm = tuple(self.node_mode(name, m, k, v) for m, k, v in modes)
            self.model.parts.append(Part(name, kind, node_modes=nm, rules=rules, span=where))
        else:
            sm = tuple(self.system_mode(name, m, k, v) for m, k, v in modes)
            self.model.parts.append(Part(name, kind, system_modes=sm, rules=rules, span=where))

    def node_mode(self, node: str, mode: str, key: Node, value: Node) -> NodeMode:
        items = {k: v for k, _, v in self.mapping(value, f"mode {mode} of {node}")}
        if set(items) != {"ros__parameters"}:
            raise self.fail(value, f"mode {mode} of node {node} must set parameters under `ros__parameters`, "
                                   "and nothing else")
        params: list[Param] = []
        self.flatten(items["ros__parameters"], "", params, 0)
        return NodeMode(mode, tuple(params), _node_span(self.file, key))

    def flatten(self, node: Node, prefix: str, out: list[Param], depth: int) -> None:
        """Nested mappings of parameters as dotted names, as ROS 2 reads them."""
        if depth > MAX_DEPTH:
            raise self.fail(node, "parameters nested too deeply")
        for name, key, value in self.mapping(node, "ros__parameters"):
            self.count(value)
            if isinstance(value, MappingNode):
                self.flatten(value, f"{prefix}{name}.", out, depth + 1)
            else:
                out.append(Param(prefix + name, _text(value), _node_span(self.file, key)))

    def system_mode(self, system: str, mode: str, key: Node, value: Node) -> SystemMode:
        parts = []
        for part, _, pvalue in self.mapping(value, f"mode {mode} of {system}"):
            self.count(pvalue)
            if not isinstance(pvalue, ScalarNode):
                raise self.fail(pvalue, f"in mode {mode} of {system}, {part} must be `state` or `state.MODE`")
            state, _, sub = pvalue.value.rpartition(".") if "." in pvalue.value else (pvalue.value, "", "")
            if state not in STATES:
                raise self.fail(pvalue, f"in mode {mode} of {system}, {part}: `{state}` is not a lifecycle state "
                                        f"({', '.join(STATES)})")
            parts.append(PartMode(part.lstrip("/"), state, sub or None, _node_span(self.file, pvalue)))
        return SystemMode(mode, tuple(parts), _node_span(self.file, key))

    def count(self, node: Node) -> None:
        self.values += 1
        if self.values > MAX_VALUES:
            raise self.fail(node, f"more than {MAX_VALUES:,} values")


def _text(node: Node) -> str:
    """A parameter's value as written (a list in flow style)."""
    if isinstance(node, ScalarNode):
        return str(node.value)
    if isinstance(node, SequenceNode):
        return "[" + ", ".join(_text(v) for v in node.value) + "]"
    return "{…}"
