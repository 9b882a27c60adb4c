"""Render Alloy text from the templates in codegen/templates/alloy/.

The meta-model (`alloy_model/reconf.als`) and the instance modules share one set of
semantic definitions, the macros of `semantics.j2`; a `StateAccess` says how those
definitions reach a configuration.

A module of a concrete architecture is built, then rendered: `describe_instance`,
`describe_plan` and `describe_architecture` decide what it says (codegen.alloy_module:
its atoms, its `fun` constants, the states and steps of a plan), and the templates only
render that description (`render_instance_module`, `render_plan_module`,
`render_planner_module`). The actions are read from their registry (checker.semantic_model.actions.KINDS).

    python -m codegen.alloy --regenerate   # rewrite alloy_model/reconf.als
    python -m codegen.alloy --check        # exit 1 if it is out of date
"""
from __future__ import annotations

import argparse
import functools
import sys
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Collection, Hashable, Iterable, Mapping, Sequence, TypeVar

from checker.semantic_model.actions import KINDS as ACTION_KINDS
from checker.semantic_model.actions import Action, kind_of, recognise
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import Component, Connector, Predicate, System

from .alloy_module import (
    EVALUATION_SIGS,
    Architecture,
    Family,
    Fun,
    InstanceData,
    InstanceModule,
    Meaning,
    PlanModule,
    PlannerModule,
    Serving,
    Step,
    plan_evaluation_sigs,
)

if TYPE_CHECKING:
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
    store: str | None = None
    joins: bool = False  # connector satisfaction as a join rather than quantifiers
    guar_atoms: bool = False  # guarantees as atoms (binary relations) rather than a ternary field
    # roles through Role atoms (`roles_of[s]`, binary relations only) rather than the
    # ternary `s.roles`, which caps the universe at about 1,290 atoms; about 3x slower
    role_atoms: bool = False

    def head(self, name: str, params: str) -> str:
        decls = [p for p in ((f"{self.var}: {self.sig}" if self.var else ""), params) if p]
        return f"{name}[{', '.join(decls)}]" if decls else name

    def call(self, name: str, args: str) -> str:
        parts = [p for p in (self.var or "", args) if p]
        return f"{name}[{', '.join(parts)}]" if parts else name

    def rel(self, name: str) -> str:
        if self.var and name == "roles" and self.role_atoms:
            return f"(roles_of[{self.var}])"
        return f"({self.var}.{name})" if self.var else f"{self.prefix}{name}"

    @property
    def roles_format(self) -> str:
        """A configuration's roles, to `format` with its variable (the actions take two)."""
        return "(roles_of[%s])" if self.role_atoms else "%s.roles"

    @property
    def csat_format(self) -> str:
        """A configuration's satisfied connectors, to `format` with its variable (an action's
        precondition reads them in both of its configurations)."""
        return "(%s.csat)" if self.materialized and not self.store else "sat_conns_def[%s]"

    def cached(self, field: str, definition: str) -> str:
        """A derived set of the configuration: the stored relation `field` when
        materialized, else a call of its definition."""
        if not self.materialized:
            return self.call(definition, "")
        return f"({self.store}.{field})" if self.store else self.rel(field)


# The meta-model: configurations are System atoms; the satisfaction relation and the
# satisfied connectors/inputs are relations fixed by facts.
META_STATE = StateAccess("s", "System", materialized=True, sat="(Sem.sat)")
# An instance module: one fixed configuration given by constants; every definition is a
# join over them (no quantifier, no variable), which the solver folds at any size.
FIXED_STATE = StateAccess(None, sat="sat", joins=True, guar_atoms=True)
# The same with ternary guarantees, for a universe small enough for ternary relations.
FIXED_TERNARY_STATE = StateAccess(None, sat="sat", joins=True)
# atoms past which a ternary relation cannot be indexed (universe³ < 2³¹)
TERNARY_ATOMS = 1_280
# atoms of the analyzer's universe besides a module's own: Int at bit width 4, and a margin
UNIVERSE_EXTRA = 32
# Configurations as System atoms whose derived sets are stored relations (the planning
# module's `var` fields).
PLAN_STATE = StateAccess("s", "System", materialized=True, sat="(Sem.sat)", joins=True, guar_atoms=True)
# The same with ternary guarantees (when the architecture's instance module has them).
PLAN_TERNARY_STATE = StateAccess("s", "System", materialized=True, sat="(Sem.sat)", joins=True)
# A plan module: the configurations are constant System atoms and every definition is a
# join over constants, which the solver folds without a variable.
PLAN_CONST_STATE = StateAccess("s", "System", sat="sat", joins=True)
# The same, for a plan module whose universe is too large for a ternary relation.
PLAN_BINARY_STATE = StateAccess("s", "System", sat="sat", joins=True, guar_atoms=True, role_atoms=True)


@functools.lru_cache(maxsize=None)
def environment() -> "jinja2.Environment":
    """The templates' environment, made once: it caches the compiled templates, and a
    large architecture renders one module per slice. Jinja loads here, on the first module
    rendered, so that importing the generator costs a command nothing at start-up."""
    import jinja2
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


def render_actions(st: StateAccess) -> str:
    """The actions' definitions alone (actions.j2), over two configurations."""
    macros = environment().get_template("actions.j2").module
    return str(macros.actions(st))  # type: ignore[attr-defined]


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


# -- Instance modules ---------------------------------------------------------------------

KINDS = {
    "component": "c", "port": "p", "functionality": "f", "connector": "k",
    "message": "m", "data": "d", "rate": "r",
}


@functools.lru_cache(maxsize=None)
def mangle(kind: str, *parts: str) -> str:
    """A valid, unique Alloy identifier for a DSL name (any characters, keywords too).

    Letters and digits stay; `_` becomes `__`, any other character `_u<hex>_`, and the
    parts are joined with `_o_`, so distinct names give distinct identifiers. (Cached: a
    plan's windows mangle the same names again.)
    """

    def esc(text: str) -> str:
        out = []
        for ch in text:
            if ch.isascii() and ch.isalnum():
                out.append(ch)
            elif ch == "_":
                out.append("__")
            else:
                out.append(f"_u{ord(ch):x}_")
        return "".join(out)

    return KINDS[kind] + "_" + "_o_".join(esc(p) for p in parts)


def union(terms: Sequence[str], empty: str) -> str:
    """Balanced union (a binary tree of `+`), or `empty` when there are no terms."""
    if not terms:
        return empty
    if len(terms) == 1:
        return terms[0]
    mid = len(terms) // 2
    return f"({union(terms[:mid], empty)} + {union(terms[mid:], empty)})"


def _empty(*sigs: str) -> str:
    product = " -> ".join(sigs)
    return "none" if len(sigs) == 1 else f"({product} - {product})"


def _fun(name: str, type_: str, terms: Sequence[str]) -> Fun:
    """A constant of relation type `type_` (`A -> B ...`), the union of `terms`."""
    return Fun(name, type_, union(terms, _empty(*type_.split(" -> "))))


def render_instance(system: System, config: Configuration, module_name: str = "instance",
                    focus: Iterable[str] | None = None, index: "SliceIndex | None" = None,
                    keep: Mapping[str, Collection[tuple[str, str]]] | None = None, valid: bool = True
                    ) -> tuple[str, dict[str, Meaning]]:
    """An Alloy module for `system` in `config`, and a map from each atom name to what it
    stands for (`codegen.alloy_module.Meaning`). The module defines `valid`, `unsatisfied:
    Functionality -> Data` (evaluate it in the `Verdict` instance) and `check Valid` (a
    counterexample means the configuration is not valid), whose `expect` says what the
    caller's verdict `valid` is: 0 (no counterexample) for a valid configuration, 1 for one
    that is not.

    With `focus` (a set of component names), the module is the slice that judges only
    those components: `valid` holds in it exactly when every assumption of the focus's
    present functionalities holds. It has the focus whole, the connectors their inputs
    are attached to, and the components publishing on those (their functionalities and
    outputs, without inputs or assumptions: only their guarantees count). Validity is
    local (an assumption reads its component's inputs, their connectors and what is
    attached to them), so the whole configuration is valid exactly when every slice of a
    partition of its components is. `index` (`slice_index(system, config)`) is what every
    slice reads, computed once: with it a slice costs what its components cost.

    `keep` ({connector: {(component, output)}}) has a slice show only those publishers of
    a connector it reads (besides the focus's own): a connector is satisfied by some
    attached output, so a slice valid with some of them is valid with all of them."""
    module = replace(describe_instance(system, config, module_name, focus, index, keep), valid=valid)
    return render_instance_module(module), module.architecture.names


@dataclass(frozen=True)
class SliceIndex:
    """What every slice of one configuration reads (`render_instance`), computed once per
    configuration instead of once per slice."""

    position: dict[str, int]                        # component -> its place in declaration order
    components: dict[str, Component]                # component name -> component (versions too)
    kinds: dict[tuple[str, str], str]               # (component, port) -> "input" / "output"
    view: Configuration                             # the configuration as Alloy reads it (alloy_view)
    roles_of: dict[str, list[tuple[str, str]]]      # component -> (connector, port) it is attached by
    publishers: dict[str, list[tuple[str, str]]]    # connector -> (component, output port) attached
    connectors: dict[str, tuple[int, Connector]]    # connector name -> (declaration place, connector)


def slice_index(system: System, config: Configuration) -> SliceIndex:
    comps = _all_components(system)
    kinds: dict[tuple[str, str], str] = {(c.name, p.name): p.kind for c in comps for p in c.ports}
    roles_of: dict[str, list[tuple[str, str]]] = {}
    publishers: dict[str, list[tuple[str, str]]] = {}
    for k, c, p in config.roles:
        roles_of.setdefault(c, []).append((k, p))
        if kinds.get((c, p)) == "output":
            publishers.setdefault(k, []).append((c, p))
    return SliceIndex(
        position={c.name: i for i, c in enumerate(comps)},
        components={c.name: c for c in comps},
        kinds=kinds,
        view=alloy_view(system, config),
        roles_of=roles_of, publishers=publishers,
        connectors={k.name: (i, k) for i, k in enumerate(system.connectors)})


def render_plan(system: System, configs: Sequence[Configuration], module_name: str = "plan",
                serving: Iterable[tuple[str, str]] = (), stable: Iterable[str] = (), binary: bool = False,
                protocols: Iterable[tuple[str, str]] = (), handover: Iterable[tuple[str, str]] = ()
                ) -> tuple[str, dict[str, Meaning]]:
    """An Alloy module for a sequence of configurations of `system` (the states of a
    plan): atoms `S0`, `S1`, ... of sig System, with the meta-model's semantics and six
    actions. Evaluate `valid[S<i>]` and `step[S<i>, S<i+1>]` (or an action predicate)
    in the `Verdict` instance. With `serving` ((connector, proxy component) pairs,
    `Plan.serving`), `lossless_states` are the configurations in which every such proxy is
    present (a degraded proxy still relays): no request is lost. With
    `stable` (connector names, `Plan.stable`), `stable_states` are those in which all of
    them are satisfied; the plan is safe only if every configuration is one. With `binary`,
    the configurations' roles are binary relations through Role atoms
    (`PLAN_BINARY_STATE`), for a universe too large for the ternary `roles`. Returns the
    text and the map from atom names to what they stand for."""
    module = describe_plan(system, configs, module_name, list(serving), list(stable), binary,
                           list(protocols), list(handover))
    return render_plan_module(module), module.architecture.names


def alloy_view(system: System, config: Configuration) -> Configuration:
    """`config` as Alloy reads it: every functionality of an absent component degraded.

    The Python engine records no mode for an absent component (removing one drops its
    entries, creating one adds them); the meta-model keeps them degraded instead (remove
    adds them, create requires them, assert AbsentDegraded). Both say the same about
    present components, which are all that `valid` and the actions' conditions read.
    """
    present = config.components
    absent = {(c.name, f.name) for c in _all_components(system) if c.name not in present
              for f in c.functionalities}
    if absent <= config.degraded:
        return config
    return Configuration(config.components, config.degraded | frozenset(absent), config.roles)


def _all_components(system: System) -> list[Component]:
    names = {c.name for c in system.components}
    return list(system.components) + [v for v in system.versions if v.name not in names]


def step_action(before: Configuration, after: Configuration) -> tuple[str, tuple[Meaning, ...]] | None:
    """The single action that the difference between two configurations would be
    (`checker.semantic_model.actions.recognise`), by name with its arguments as the atoms' meanings, or
    None when the difference is not one change."""
    action = recognise(before, after)
    if action is None:
        return None
    return action.kind, kind_of(action).alloy_args(action)


# -- Building a module's description ------------------------------------------------------

@dataclass
class _Data:
    """The data atoms, one per distinct (message, rate) in the order they are met, with
    the message types and rates they name."""

    names: dict[str, Meaning]
    atoms: dict[tuple[str, Fraction | None], str] = field(default_factory=dict)
    messages: dict[str, str] = field(default_factory=dict)
    rates: set[Fraction] = field(default_factory=set)
    _quick: dict[tuple[str, int | None, int | None], str] = field(default_factory=dict, repr=False)

    def atom(self, pred: Predicate | None) -> str:
        if pred is None or pred.message is None:
            return "Nothing"
        hz = pred.hz
        # looked up by the rate's numerator and denominator: hashing a Fraction is slow Python
        quick = (pred.message, None, None) if hz is None else (pred.message, hz.numerator, hz.denominator)
        found = self._quick.get(quick)
        if found is not None:
            return found
        key = (pred.message, hz)
        if key not in self.atoms:
            atom = f"d_{len(self.atoms)}"
            self.atoms[key] = atom
            self.names[atom] = ("data", pred.message, "" if hz is None else str(hz))
            self.mtype(pred.message)
            if hz is not None:
                self.rates.add(hz)
        self._quick[quick] = self.atoms[key]
        return self.atoms[key]

    def mtype(self, message: str) -> str:
        """The atom of a message type."""
        if message not in self.messages:
            self.messages[message] = mangle("message", message)
            self.names[self.messages[message]] = ("message", message)
        return self.messages[message]


@dataclass
class _Parts:
    """The atoms of an architecture and its relations as terms, while they are collected."""

    names: dict[str, Meaning]
    data: _Data
    comps: dict[str, str] = field(default_factory=dict)
    ports: dict[tuple[str, str], str] = field(default_factory=dict)
    funcs: dict[tuple[str, str], str] = field(default_factory=dict)
    conns: dict[str, str] = field(default_factory=dict)
    inputs: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    # (functionality, output, meaning, normal datum, degraded datum) per guarantee
    guarantees: list[tuple[str, str, Meaning, str, str]] = field(default_factory=list)
    rel: dict[str, list[tuple[str, ...]]] = field(default_factory=lambda: {k: [] for k in (
        "inputs", "outputs", "funcs", "iasm", "assoc_in", "assoc_out", "nasms", "gfunc",
        "gout", "gn", "gd", "nguar", "dguar", "cguar", "envg", "ptype", "single", "service")})

    def name(self, atom: str, meaning: Meaning) -> str:
        self.names[atom] = meaning
        return atom


@dataclass(frozen=True)
class _Scope:
    """What a module shows: the components (whole where `judged`, else only the outputs in
    `context`), the connectors, and the configurations as Alloy reads them."""

    comps: list[Component]
    connectors: Sequence[Connector]
    configs: list[Configuration]
    focus: set[str] | None = None
    context: set[tuple[str, str]] = field(default_factory=set)
    index: SliceIndex | None = None

    def judged(self, comp: str) -> bool:
        return self.focus is None or comp in self.focus


def _whole(system: System, configs: Sequence[Configuration]) -> _Scope:
    return _Scope(_all_components(system), system.connectors, [alloy_view(system, c) for c in configs])


def _slice(system: System, config: Configuration, focus: Iterable[str], index: SliceIndex | None,
           keep: Mapping[str, Collection[tuple[str, str]]] | None) -> _Scope:
    """The slice judging `focus` (see `render_instance`): the focus whole; of the other
    components only the outputs attached to the connectors the focus reads, and the
    functionalities behind them; only those connectors, all read through the index."""
    focus = set(focus)
    index = index if index is not None else slice_index(system, config)
    read = {k for c in focus for k, p in index.roles_of.get(c, ()) if index.kinds.get((c, p)) == "input"}
    keep = keep or {}
    context = {(c, p) for k in read for c, p in index.publishers.get(k, ())
               if c not in focus and (k not in keep or (c, p) in keep[k])}
    wanted = focus | {c for c, _ in context}
    comps = [index.components[n] for n in sorted(wanted & index.components.keys(), key=index.position.__getitem__)]
    connectors = [index.connectors[n][1] for n in sorted(read & index.connectors.keys(),
                                                         key=lambda n: index.connectors[n][0])]
    return _Scope(comps, connectors, [index.view], focus, context, index)


def _declare_ports(parts: _Parts, scope: _Scope, c: Component, ca: str) -> None:
    data = parts.data
    for p in c.ports:
        if not scope.judged(c.name) and (p.kind == "input" or (c.name, p.name) not in scope.context):
            continue
        pa = parts.ports[c.name, p.name] = parts.name(mangle("port", c.name, p.name), ("port", c.name, p.name))
        parts.rel["ptype"].append((pa, data.mtype(p.message)))
        if p.kind == "input":
            parts.inputs.append(pa)
            parts.rel["inputs"].append((ca, pa))
            parts.rel["iasm"].append((pa, data.atom(p.assumption)))
        else:
            parts.outputs.append(pa)
            parts.rel["outputs"].append((ca, pa))


def _declare_functionalities(parts: _Parts, scope: _Scope, c: Component, ca: str) -> None:
    judged = scope.judged(c.name)
    ports, rel, atom, name = parts.ports, parts.rel, parts.data.atom, c.name
    kinds = {p.name: p.kind for p in c.ports}
    for f in c.functionalities:
        if not judged and not any((name, pname) in ports for pname in f.ports):
            continue
        fa = parts.funcs[name, f.name] = parts.name(mangle("functionality", name, f.name),
                                                    ("functionality", name, f.name))
        rel["funcs"].append((ca, fa))
        for pname in f.ports:
            pa = ports.get((name, pname))
            if pa is None or pname not in kinds:
                continue
            if kinds[pname] == "input":
                rel["assoc_in"].append((fa, pa))
                continue
            rel["assoc_out"].append((fa, pa))
            # written once the encoding is chosen (see `_guarantee_atoms`)
            normal = atom(f.normal.guarantee(pname)) if f.normal is not None else "Nothing"
            degraded = atom(f.degraded.guarantee(pname)) if f.degraded is not None else "Nothing"
            parts.guarantees.append((fa, pa, ("guarantee", name, f.name, pname), normal, degraded))
        if f.normal is not None and judged:
            nasms = rel["nasms"]
            for a in f.normal.assumptions:
                nasms.append((fa, atom(a)))


def _collect(system: System, scope: _Scope, names: dict[str, Meaning]) -> _Parts:
    """The atoms and relation terms of the architecture in `scope`, in declaration order
    (the data atoms as first met)."""
    parts = _Parts(names, _Data(names))
    for c in scope.comps:
        ca = parts.comps[c.name] = parts.name(mangle("component", c.name), ("component", c.name))
        _declare_ports(parts, scope, c, ca)
        _declare_functionalities(parts, scope, c, ca)
    for k in scope.connectors:
        ka = parts.conns[k.name] = parts.name(mangle("connector", k.name), ("connector", k.name))
        parts.rel["cguar"].append((ka, parts.data.atom(k.guarantee)))
        if k.kind == "service":
            parts.rel["service"].append((ka,))
        elif k.single:
            parts.rel["single"].append((ka,))
    for e in system.environment:
        parts.rel["envg"].append((parts.data.atom(e.guarantee),))
    return parts


def _rate_atoms(parts: _Parts) -> list[tuple[Fraction, str]]:
    """The rates in order, an atom each."""
    return [(hz, parts.name(f"r_{i}", ("rate", str(hz)))) for i, hz in enumerate(sorted(parts.data.rates))]


def _guarantee_atoms(parts: _Parts, ternary: bool) -> list[str]:
    """The guarantees' relations: a ternary relation (Functionality -> Output -> Data, the
    meta-model's own encoding), or an atom each; the atoms."""
    guar_atoms: list[str] = []
    rel = parts.rel
    for fa, pa, meaning, normal, degraded in parts.guarantees:
        if ternary:
            rel["nguar"].append((fa, pa, normal))
            rel["dguar"].append((fa, pa, degraded))
            continue
        ga = parts.name(f"g_{len(guar_atoms)}", meaning)
        guar_atoms.append(ga)
        rel["gfunc"].append((ga, fa))
        rel["gout"].append((ga, pa))
        rel["gn"].append((ga, normal))
        rel["gd"].append((ga, degraded))
    return guar_atoms


def _families(parts: _Parts, rates: list[tuple[Fraction, str]], guar_atoms: list[str] | None) -> tuple[Family, ...]:
    """The sigs of the atoms, in declaration order (guarantee atoms when not ternary)."""
    families = [
        Family("MType", tuple(sorted(parts.data.messages.values()))),
        Family("Rate", tuple(ra for _, ra in rates)),
        Family("Data", ("Nothing",), closed=False),
        Family("Msg", tuple(parts.data.atoms.values()), "Data"),
        Family("Component", tuple(parts.comps.values())),
        Family("Port", (), closed=False),
        Family("Input", tuple(parts.inputs), "Port"),
        Family("Output", tuple(parts.outputs), "Port"),
        Family("Functionality", tuple(parts.funcs.values())),
        Family("Connector", tuple(parts.conns.values())),
    ]
    if guar_atoms is not None:
        families.append(Family("Guar", tuple(guar_atoms)))
    return tuple(families)


def _grouped(pairs: list[tuple[str, ...]]) -> list[str]:
    """`(a, x)` pairs as terms `a -> (x + y + ...)`, one per distinct `a` (order kept)."""
    by_left: dict[str, list[str]] = {}
    for left, right in pairs:
        by_left.setdefault(left, []).append(right)
    return [f"{a} -> {union(rs, 'none')}" if len(rs) > 1 else f"{a} -> {rs[0]}" for a, rs in by_left.items()]


def _terms(tuples: Iterable[tuple[str, ...]]) -> list[str]:
    return [" -> ".join(t) for t in tuples]


def _fixed_relations(parts: _Parts, rates: list[tuple[Fraction, str]]) -> dict[str, list[tuple[str, ...]]]:
    """Every fixed relation of the architecture as tuples of atoms, by name (besides the
    collected ones: the rates' order, each datum's message type and rate)."""
    rate_of = dict(rates)
    atoms = parts.data.atoms.items()
    return {**parts.rel,
            "rate_next": [(a, b) for (_, a), (_, b) in zip(rates, rates[1:])],
            "mtype": [(atom, parts.data.messages[msg]) for (msg, _), atom in atoms],
            "rate": [(atom, rate_of[hz]) for (_, hz), atom in atoms if hz is not None],
            "envg": sorted(set(parts.rel["envg"]))}


def _architecture_funs(parts: _Parts, rates: list[tuple[Fraction, str]], ternary: bool) -> tuple[Fun, ...]:
    """The fixed relations as constants."""
    rel = {k: (_grouped(v) if k in ("inputs", "outputs", "funcs", "assoc_in", "assoc_out", "nasms") else _terms(v))
           for k, v in _fixed_relations(parts, rates).items()}
    guarantees = ([_fun("nguar", "Functionality -> Output -> Data", rel["nguar"]),
                   _fun("dguar", "Functionality -> Output -> Data", rel["dguar"])] if ternary else
                  [_fun("gfunc", "Guar -> Functionality", rel["gfunc"]), _fun("gout", "Guar -> Output", rel["gout"]),
                   _fun("gn", "Guar -> Data", rel["gn"]), _fun("gd", "Guar -> Data", rel["gd"])])
    return (
        _fun("rate_next", "Rate -> Rate", rel["rate_next"]),
        _fun("mtype", "Msg -> MType", rel["mtype"]),
        _fun("rate", "Msg -> Rate", rel["rate"]),
        _fun("inputs", "Component -> Input", rel["inputs"]),
        _fun("outputs", "Component -> Output", rel["outputs"]),
        _fun("funcs", "Component -> Functionality", rel["funcs"]),
        _fun("iasm", "Input -> Data", rel["iasm"]),
        _fun("assoc_in", "Functionality -> Input", rel["assoc_in"]),
        _fun("assoc_out", "Functionality -> Output", rel["assoc_out"]),
        _fun("nasms", "Functionality -> Data", rel["nasms"]),
        *guarantees,
        _fun("cguar", "Connector -> Data", rel["cguar"]),
        _fun("ptype", "Port -> MType", rel["ptype"]),
        Fun("envg", "set Data", union(rel["envg"], "(Data - Data)")),
        Fun("single", "set Connector", union(rel["single"], "(Connector - Connector)")),
        Fun("service", "set Connector", union(rel["service"], "(Connector - Connector)")),
    )


def _describe_architecture(system: System, scope: _Scope, ternary: bool | None,
                           names: dict[str, Meaning] | None = None) -> tuple[Architecture, _Parts]:
    """The architecture in `scope`, with its guarantees ternary when `ternary`, or (None)
    when the universe allows a ternary relation. `names` may hold atoms named before."""
    parts = _collect(system, scope, names if names is not None else {})
    rates = _rate_atoms(parts)
    if ternary is None:
        # the analyzer's symmetry detection refines its partition once per one-sig atom,
        # about quadratic in the atoms (half of a module's fixed cost): ternary guarantees
        # when the universe (with room for the analyzer's Int atoms) can index them
        ternary = len(parts.names) + UNIVERSE_EXTRA <= TERNARY_ATOMS
    guar_atoms = _guarantee_atoms(parts, ternary)
    arch = Architecture(_families(parts, rates, None if ternary else guar_atoms),
                        _architecture_funs(parts, rates, ternary), not ternary, parts.names)
    return arch, parts


def describe_architecture(system: System) -> Architecture:
    """The atoms and fixed relations of `system` exactly as its instance modules declare
    them (a planning module's architecture)."""
    arch, _ = _describe_architecture(system, _whole(system, []), None)
    return arch


def _configuration_tuples(parts: _Parts, scope: _Scope) -> tuple[list[str], list[str], list[tuple[str, str]]]:
    """The one configuration's present components, degraded functionalities and roles
    (connector, port), as atoms of `parts`."""
    (config,) = scope.configs
    index = scope.index
    roles: Iterable[tuple[str, str, str]]
    if index is not None:       # a slice: only its connectors, components and functionalities
        roles = sorted({(k, c, p) for c in parts.comps for k, p in index.roles_of.get(c, ())})
        comps = sorted(n for n in parts.comps if n in config.components)
        degraded = sorted(cf for cf in parts.funcs if cf in config.degraded)
    else:
        roles, comps, degraded = sorted(config.roles), sorted(config.components), sorted(config.degraded)
    return ([parts.comps[n] for n in comps if n in parts.comps],
            [parts.funcs[cf] for cf in degraded if cf in parts.funcs],
            [(parts.conns[k], parts.ports[c, p]) for k, c, p in roles if k in parts.conns and (c, p) in parts.ports])


def _instance_configuration(parts: _Parts, scope: _Scope) -> tuple[Fun, ...]:
    """The one configuration's relations; the roles grouped (a connector -> a union of
    ports): fewer products for Alloy to type-check."""
    comps, degraded, roles = _configuration_tuples(parts, scope)
    by_conn: dict[str, list[str]] = {}
    for k, port in roles:
        by_conn.setdefault(k, []).append(port)
    return (
        Fun("comps", "set Component", union(comps, "none")),
        Fun("degraded", "set Functionality", union(degraded, "none")),
        _fun("roles", "Connector -> Port", [f"{k} -> {union(ps, 'none')}" for k, ps in by_conn.items()]),
    )


def _scope(system: System, config: Configuration, focus: Iterable[str] | None, index: SliceIndex | None,
           keep: Mapping[str, Collection[tuple[str, str]]] | None) -> _Scope:
    return _whole(system, [config]) if focus is None else _slice(system, config, focus, index, keep)


def describe_instance(system: System, config: Configuration, module_name: str = "instance",
                      focus: Iterable[str] | None = None, index: SliceIndex | None = None,
                      keep: Mapping[str, Collection[tuple[str, str]]] | None = None) -> InstanceModule:
    """The instance module of `render_instance`, before it is text."""
    scope = _scope(system, config, focus, index, keep)
    arch, parts = _describe_architecture(system, scope, None)
    return InstanceModule(module_name, system.name, arch, _instance_configuration(parts, scope))


def _architecture_data(system: System, scope: _Scope, names: dict[str, Meaning] | None = None
                       ) -> tuple[_Parts, dict[str, tuple[str, ...]], dict[str, tuple[tuple[str, ...], ...]]]:
    """The architecture in `scope` as instance data: its parts, each sig's own atoms and each
    fixed field's tuples, guarantees as atoms (what an instance module writes as `one sig`s
    and `fun` constants)."""
    parts = _collect(system, scope, names if names is not None else {})
    rates = _rate_atoms(parts)
    atoms = {f.parent: f.atoms for f in _families(parts, rates, _guarantee_atoms(parts, ternary=False))}
    atoms["Nothing"] = ("Nothing",)
    atoms.pop("Data")
    fixed = _fixed_relations(parts, rates)
    for subset in ("envg", "single", "service"):
        atoms[subset] = tuple(d for (d,) in fixed.pop(subset))
    return parts, atoms, {name: tuple(tuples) for name, tuples in fixed.items()}


def describe_instance_data(system: System, config: Configuration, focus: Iterable[str] | None = None,
                           index: SliceIndex | None = None,
                           keep: Mapping[str, Collection[tuple[str, str]]] | None = None) -> InstanceData:
    """The same configuration (or slice: see `render_instance`) as an instance of the
    evaluation module (`render_evaluation_module`)."""
    scope = _scope(system, config, focus, index, keep)
    parts, atoms, fields = _architecture_data(system, scope)
    comps, degraded, roles = _configuration_tuples(parts, scope)
    atoms.update(comps=tuple(comps), degraded=tuple(degraded))
    fields["roles"] = tuple(roles)
    _attached_types(fields, {p for _, p in roles})
    return InstanceData(system.name, atoms, fields, parts.names)


def _attached_types(fields: dict[str, tuple[tuple[str, ...], ...]], attached: set[str]) -> None:
    """Only the attached ports' message types: the one rule that reads them (`typed_ok`) reads
    those alone, and an instance is read faster without the others."""
    fields["ptype"] = tuple(t for t in fields["ptype"] if t[0] in attached)


def describe_plan_data(system: System, configs: Sequence[Configuration], serving: Sequence[tuple[str, str]] = (),
                       stable: Sequence[str] = (), protocols: Sequence[tuple[str, str]] = (),
                       handover: Sequence[tuple[str, str]] = (),
                       actions: Sequence[Action | None] | None = None) -> InstanceData:
    """A plan's configurations (see `render_plan`) as an instance of the plan evaluation
    module (`render_plan_evaluation_module`): states S0, S1, ..., their attachments through
    Role atoms, and a Step atom per step with its action's arguments (the plan's `actions`,
    one per step, when given; a step given as None is no action's)."""
    scope = _whole(system, configs)
    states = [f"S{i}" for i in range(len(scope.configs))]
    parts, atoms, fields = _architecture_data(system, scope, {s: ("state", str(i)) for i, s in enumerate(states)})
    roles: dict[tuple[str, str], str] = {}
    comps, degraded, sroles = [], [], []
    for state, config in zip(states, scope.configs):
        comps += [(state, parts.comps[c]) for c in sorted(config.components) if c in parts.comps]
        degraded += [(state, parts.funcs[f]) for f in sorted(config.degraded) if f in parts.funcs]
        for k, c, p in sorted(config.roles):
            if k in parts.conns and (c, p) in parts.ports:
                sroles.append((state, roles.setdefault((parts.conns[k], parts.ports[c, p]), f"a_{len(roles)}")))
    atoms.update(System=tuple(states), Role=tuple(roles.values()))
    fields.update(comps=tuple(comps), degraded=tuple(degraded), sroles=tuple(sroles),
                  role_conn=tuple((a, k) for (k, _), a in roles.items()),
                  role_port=tuple((a, p) for (_, p), a in roles.items()))
    _attached_types(fields, {p for _, p in roles})
    _plan_step_data(scope.configs, states, parts, atoms, fields, actions)
    _serving_data(parts, list(serving), list(stable), list(protocols), list(handover), atoms, fields)
    return InstanceData(system.name, atoms, fields, parts.names)


def _plan_step_data(configs: list[Configuration], states: list[str], parts: _Parts,
                    atoms: dict[str, tuple[str, ...]], fields: dict[str, tuple[tuple[str, ...], ...]],
                    actions: Sequence[Action | None] | None = None) -> None:
    """A Step atom per step: the states around it, and the action it is with its arguments
    (one field per kind: its `params`) and its `<action>_steps`: the plan's own `actions`
    when given, else the one action the difference between the two states is, if any. A
    step whose arguments the module does not show is no action's."""
    params = {k.name: k.params for k in ACTION_KINDS}
    names = [f"t{i}" for i in range(len(configs) - 1)]
    rel: dict[str, list[tuple[str, ...]]] = {"pre": [], "post": []}
    kinds: dict[str, list[str]] = {kind: [] for kind in params}
    by_meaning = {meaning: atom for atom, meaning in parts.names.items()}
    steps = (_steps(configs, states, by_meaning) if actions is None
             else tuple(_declared(a, states[i], states[i + 1], by_meaning) for i, a in enumerate(actions)))
    for t, step in zip(names, steps):
        if step is None:
            continue
        kinds[step.action].append(t)
        for kind, arg in zip(params[step.action], step.args):
            rel.setdefault(f"a_{kind}", []).append((t, arg))
    rel["pre"] = [(t, s) for t, s in zip(names, states)]
    rel["post"] = [(t, s) for t, s in zip(names, states[1:])]
    atoms["Step"] = tuple(names)
    atoms.update({f"{kind}_steps": tuple(members) for kind, members in kinds.items()})
    fields.update({name: tuple(tuples) for name, tuples in rel.items()})


def _declared(action: Action | None, before: str, after: str, atoms: Mapping[Meaning, str]) -> Step | None:
    """A plan's own step, or None when there is none or the module does not show its arguments."""
    if action is None:
        return None
    args = kind_of(action).alloy_args(action)
    if any(m not in atoms for m in args):
        return None
    return Step(action.kind, before, after, tuple(atoms[m] for m in args))


def _serving_data(parts: _Parts, serving: list[tuple[str, str]], stable: list[str], protocols: list[tuple[str, str]],
                  handover: list[tuple[str, str]], atoms: dict[str, tuple[str, ...]],
                  fields: dict[str, tuple[tuple[str, ...], ...]]) -> None:
    """What the plan must keep serving and keep satisfied (see `render_plan`), as sets."""
    missing = [k for k, c in serving + handover if k not in parts.conns or c not in parts.comps]
    missing += [k for k in stable if k not in parts.conns]
    if missing:
        raise ValueError(f"the plan names what the architecture lacks: {missing}")
    served = {c for _, c in serving}
    atoms["proxies"] = tuple(fa for (c, _), fa in parts.funcs.items() if c in served)
    atoms["client_conns"] = tuple(sorted({parts.conns[k] for k, _ in serving}))
    atoms["handing"] = tuple(sorted({parts.comps[c] for _, c in handover}))
    atoms["handed_conns"] = tuple(sorted({parts.conns[k] for k, _ in handover}))
    atoms["stable_conns"] = tuple(sorted({parts.conns[k] for k in stable}))
    if protocols or handover:   # the proxies' requests must reach one of these present protocols
        atoms["proxy_comps"] = tuple(sorted({parts.comps[c] for c in served}))
        fields["protocols"] = tuple(sorted({(parts.comps[x], parts.comps[p]) for x, p in protocols
                                            if x in parts.comps and p in parts.comps}))


def _plan_relations(configs: list[Configuration], states: list[str], parts: _Parts,
                    binary: bool = False) -> tuple[dict[str, list[str]], list[str]]:
    """The configurations' relations (System -> ...) by what changes: what every state has
    is written once (`System -> x`), and each other element with the states that have it
    (`(S3 + S4) -> x`), elements with the same states grouped. A plan changes one element
    per step, so the text grows with the architecture plus the changes, not with their
    product. With `binary`, roles are `System -> Role` with `role_conn`/`role_port`, and
    the Role atoms are returned."""

    def who(held: tuple[int, ...]) -> str:
        return "System" if len(held) == len(configs) else union([states[i] for i in held], "none")

    rel: dict[str, list[str]] = {k: [] for k in ("comps", "degraded", "roles", "role_conn", "role_port")}
    comps = _by_states([(parts.comps[n] for n in c.components if n in parts.comps) for c in configs])
    rel["comps"] = [f"{who(held)} -> {union(sorted(members), 'none')}" for held, members in comps]
    degraded = _by_states([(parts.funcs[cf] for cf in c.degraded if cf in parts.funcs) for c in configs])
    rel["degraded"] = [f"{who(held)} -> {union(sorted(members), 'none')}" for held, members in degraded]
    roles = _by_states([((parts.conns[k], parts.ports[c, p]) for k, c, p in config.roles
                         if k in parts.conns and (c, p) in parts.ports) for config in configs])
    role_atoms: dict[tuple[str, str], str] = {}
    for held, members in roles:
        if binary:
            for member in sorted(members):
                role_atoms.setdefault(member, f"a_{len(role_atoms)}")
            body = union(sorted(role_atoms[m] for m in members), "none")
        else:
            per_conn: dict[str, list[str]] = {}
            for k, port in sorted(members):
                per_conn.setdefault(k, []).append(port)
            body = union([f"{k} -> {union(ps, 'none')}" for k, ps in per_conn.items()], "none")
        rel["roles"].append(f"{who(held)} -> {body}")
    for (k, port), atom in role_atoms.items():
        rel["role_conn"].append(f"{atom} -> {k}")
        rel["role_port"].append(f"{atom} -> {port}")
    return rel, list(role_atoms.values())


_T = TypeVar("_T", bound=Hashable)


def _by_states(per_state: Sequence[Iterable[_T]]) -> list[tuple[tuple[int, ...], list[_T]]]:
    """The elements held in each state, grouped by the states that hold them, fewest first."""
    holders: dict[_T, list[int]] = {}
    for i, items in enumerate(per_state):
        for item in items:
            holders.setdefault(item, []).append(i)
    by_states: dict[tuple[int, ...], list[_T]] = {}
    for item, indices in holders.items():
        by_states.setdefault(tuple(indices), []).append(item)
    return sorted(by_states.items(), key=lambda kv: (len(kv[0]), kv[0]))


def _plan_configurations(rel: dict[str, list[str]], binary: bool) -> tuple[Fun, ...]:
    funs = (_fun("comps", "System -> Component", rel["comps"]),
            _fun("degraded", "System -> Functionality", rel["degraded"]))
    if binary:
        return funs + (_fun("sroles", "System -> Role", rel["roles"]),
                       _fun("role_conn", "Role -> Connector", rel["role_conn"]),
                       _fun("role_port", "Role -> Port", rel["role_port"]))
    return funs + (_fun("roles", "System -> Connector -> Port", rel["roles"]),)


def _steps(configs: Sequence[Configuration], states: list[str], atoms: Mapping[Meaning, str]) -> tuple[Step | None, ...]:
    """Per step, the action the difference between its two configurations is, with its
    arguments' atoms (None where it is not one action)."""
    steps: list[Step | None] = []
    for i, (before, after) in enumerate(zip(configs, configs[1:])):
        found = step_action(before, after)
        steps.append(None if found is None else
                     Step(found[0], states[i], states[i + 1], tuple(atoms[m] for m in found[1])))
    return tuple(steps)


def _plan_steps(configs: list[Configuration], states: list[str], atoms: Mapping[Meaning, str]
                ) -> tuple[tuple[Step | None, ...], str]:
    """The steps (`_steps`), and `ok_steps`, each one-action step's state -> its action."""
    steps = _steps(configs, states, atoms)
    terms = [f"({{s: {s.before} | {_call(s)}}} -> {s.sig})" for s in steps if s is not None]
    return steps, union(terms, _empty("System", "Action"))


def _call(step: Step) -> str:
    return f"{step.action}[{step.before}, {step.after}, {', '.join(step.args)}]"


def _serving(parts: _Parts, comps: Sequence[Component], serving: list[tuple[str, str]],
             protocols: list[tuple[str, str]], handover: list[tuple[str, str]]) -> Serving | None:
    """What the plan must keep serving (see `render_plan`), or None when it names nothing."""
    if not serving and not handover:
        return None
    proxies = [parts.funcs[c, f.name] for _, c in serving for comp in comps if comp.name == c
               for f in comp.functionalities if (c, f.name) in parts.funcs]
    conns = [parts.conns[k] for k, _ in serving if k in parts.conns]
    handed = [parts.conns[k] for k, _ in handover if k in parts.conns]
    if len(conns) != len(serving) or (serving and not proxies) or len(handed) != len(handover) \
            or any(c not in parts.comps for _, c in handover):
        raise ValueError(f"serving names what the architecture lacks: {serving + handover}")
    watch = Serving(union(proxies, "none"), union(conns, "none"),
                    union(sorted({parts.comps[c] for _, c in handover}), "none"), union(handed, "none"))
    if not protocols and not handover:
        return watch
    # the proxies' requests must reach one of these (present) protocols
    return replace(watch, proxy_comps=union(sorted({parts.comps[c] for _, c in serving}), "none"),
                   protocols=union(sorted(f"{parts.comps[x]} -> {parts.comps[p]}" for x, p in protocols
                                          if x in parts.comps and p in parts.comps), _empty("Component", "Component")))


def _stable(parts: _Parts, stable: list[str]) -> str | None:
    if not stable:
        return None
    missing = [k for k in stable if k not in parts.conns]
    if missing:
        raise ValueError(f"stable names connectors the architecture lacks: {missing}")
    return union([parts.conns[k] for k in stable], "none")


def describe_plan(system: System, configs: Sequence[Configuration], module_name: str = "plan",
                  serving: list[tuple[str, str]] | None = None, stable: list[str] | None = None,
                  binary: bool = False, protocols: list[tuple[str, str]] | None = None,
                  handover: list[tuple[str, str]] | None = None) -> PlanModule:
    """The plan module of `render_plan`, before it is text. Guarantees are ternary
    unless the roles are `binary` (a universe past what a ternary relation can index)."""
    scope = _whole(system, configs)
    states = [f"S{i}" for i in range(len(scope.configs))]
    arch, parts = _describe_architecture(system, scope, not binary, {s: ("state", str(i)) for i, s in enumerate(states)})
    rel, role_atoms = _plan_relations(scope.configs, states, parts, binary)
    roles = (Family("Role", tuple(role_atoms)),) if binary else ()
    steps, ok_steps = _plan_steps(scope.configs, states, arch.atoms())
    return PlanModule(module_name, system.name, arch, tuple(states), _plan_configurations(rel, binary), roles,
                      binary, tuple(k.name.capitalize() for k in ACTION_KINDS), steps, ok_steps,
                      _serving(parts, scope.comps, serving or [], protocols or [], handover or []),
                      _stable(parts, stable or []))


# -- Rendering a description --------------------------------------------------------------

# the plan evaluation module's sigs, with a `<action>_steps` for each action of the registry
PLAN_EVALUATION_SIGS = plan_evaluation_sigs(tuple(k.name for k in ACTION_KINDS))


@functools.lru_cache(maxsize=1)
def render_plan_evaluation_module() -> str:
    """The plan evaluation module: the sigs of `PLAN_EVALUATION_SIGS`, the shared semantics
    and the six actions over them, and `plan_safe`. Every instance of it
    (`describe_plan_data`) is a plan, or a window of its steps."""
    return environment().get_template("plan_evaluate.als.j2").render(
        st=PLAN_BINARY_STATE, sigs=PLAN_EVALUATION_SIGS, kinds=ACTION_KINDS)


@functools.lru_cache(maxsize=1)
def render_evaluation_module() -> str:
    """The evaluation module: the sigs and fields of EVALUATION_SIGS, the satisfaction
    relation and the shared semantics over them, and `unsatisfied`. Every instance of it
    (`describe_instance_data`, codegen.alloy_xml) is one configuration; `valid` is evaluated
    in it (docs/soundness.md, "Judging by evaluation")."""
    return environment().get_template("evaluate.als.j2").render(st=FIXED_STATE, sigs=EVALUATION_SIGS)


def render_instance_module(module: InstanceModule) -> str:
    st = FIXED_STATE if module.architecture.guar_atoms else FIXED_TERNARY_STATE
    return environment().get_template("instance.als.j2").render(st=st, m=module, arch=module.architecture)


def render_plan_module(module: PlanModule) -> str:
    st = PLAN_BINARY_STATE if module.binary else PLAN_CONST_STATE
    return environment().get_template("plan.als.j2").render(st=st, m=module, arch=module.architecture)


def render_planner_module(module: PlannerModule) -> str:
    """A planning module (checker.planning.alloy_search), its guarantees encoded as its
    architecture's instance modules encode them."""
    st = PLAN_STATE if module.architecture.guar_atoms else PLAN_TERNARY_STATE
    return environment().get_template("planner.als.j2").render(st=st, m=module, arch=module.architecture)


if __name__ == "__main__":
    sys.exit(main())
