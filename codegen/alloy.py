"""Render Alloy text from the templates in codegen/templates/alloy/.

The meta-model (`alloy_model/reconf.als`) and the instance modules share one set of
semantic definitions, the macros of `semantics.j2`; a `StateAccess` says how those
definitions reach a configuration.

    python -m codegen.alloy --regenerate   # rewrite alloy_model/reconf.als
    python -m codegen.alloy --check        # exit 1 if it is out of date
"""
from __future__ import annotations

import argparse
import functools
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

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
def environment() -> jinja2.Environment:
    """The templates' environment, made once: it caches the compiled templates, and a
    large architecture renders one module per slice."""
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


def union(terms: list[str], empty: str) -> str:
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


def _one_sigs(parent: str, names: list[str], extends: str = "") -> list[str]:
    """An abstract sig and one `one sig` per atom (balanced lines of 8)."""
    out = [f"abstract sig {parent} {extends}{{}}".replace("  ", " ")]
    for i in range(0, len(names), 8):
        out.append(f"one sig {', '.join(names[i:i + 8])} extends {parent} {{}}")
    return out


def render_instance(system: Any, config: Any, module_name: str = "instance",
                    focus: Any = None, index: "SliceIndex | None" = None,
                    keep: Any = None) -> tuple[str, dict[str, tuple[str, ...]]]:
    """An Alloy module for `system` (reconf_dsl.ir.System) in `config`
    (checker.model.config.Configuration); see `_render`.

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
    if focus is None:
        return _render(system, [config], module_name, plan=False)
    focus = set(focus)
    index = index if index is not None else slice_index(system, config)
    read = {k for c in focus for k, p in index.roles_of.get(c, ()) if index.kinds.get((c, p)) == "input"}
    keep = keep or {}
    context = {(c, p) for k in read for c, p in index.publishers.get(k, ())
               if c not in focus and (k not in keep or (c, p) in keep[k])}
    return _render(system, [config], module_name, plan=False, slice_=(focus, context, read, index))


@dataclass(frozen=True)
class SliceIndex:
    """What every slice of one configuration reads (`render_instance`), computed once per
    configuration instead of once per slice."""

    position: dict[str, int]                        # component -> its place in declaration order
    components: dict[str, Any]                      # component name -> component (versions too)
    kinds: dict[tuple[str, str], str]               # (component, port) -> "input" / "output"
    view: Any                                       # the configuration as Alloy reads it (alloy_view)
    roles_of: dict[str, list[tuple[str, str]]]      # component -> (connector, port) it is attached by
    publishers: dict[str, list[tuple[str, str]]]    # connector -> (component, output port) attached
    connectors: dict[str, tuple[int, Any]]          # connector name -> (declaration place, connector)


def slice_index(system: Any, config: Any) -> SliceIndex:
    comps = _all_components(system)
    kinds = {(c.name, p.name): p.kind for c in comps for p in c.ports}
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


def render_plan(system: Any, configs: Sequence[Any], module_name: str = "plan",
                serving: Any = (), stable: Any = (), binary: bool = False,
                protocols: Any = (), handover: Any = ()) -> tuple[str, dict[str, tuple[str, ...]]]:
    """An Alloy module for a sequence of configurations of `system` (the states of a
    plan): atoms `S0`, `S1`, ... of sig System, with the meta-model's semantics and six
    actions. Evaluate `valid[S<i>]` and `step[S<i>, S<i+1>]` (or an action predicate)
    in the `Verdict` instance. With `serving` ((connector, proxy component) pairs,
    `Plan.serving`), `lossless_states` are the configurations in which every such proxy is
    present (a degraded proxy still relays): no request is lost. With
    `stable` (connector names, `Plan.stable`), `stable_states` are those in which all of
    them are satisfied; the plan is safe only if every configuration is one. With `binary`,
    the configurations' roles are binary relations through Role atoms
    (`PLAN_BINARY_STATE`), for a universe too large for the ternary `roles`."""
    return _render(system, configs, module_name, plan=True, serving=list(serving), stable=list(stable),
                   binary=binary, protocols=list(protocols), handover=list(handover))


def alloy_view(system: Any, config: Any) -> Any:
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
    return type(config)(config.components, config.degraded | frozenset(absent), config.roles)


def _all_components(system: Any) -> list[Any]:
    names = {c.name for c in system.components}
    return list(system.components) + [v for v in system.versions if v.name not in names]


def step_action(before: Any, after: Any) -> tuple[str, list[tuple[str, Any]]] | None:
    """The single action that the difference between two configurations would be, with its
    arguments as (kind, DSL key), or None when the difference is not one change.

    The modes of a created or removed component's functionalities are part of that action
    (whichever way the configurations record them), not a change of their own."""
    removed = before.components - after.components
    created = after.components - before.components
    moved = removed | created
    detached = before.roles - after.roles
    attached = after.roles - before.roles
    degraded = {f for f in after.degraded - before.degraded if f[0] not in moved}
    upgraded = {f for f in before.degraded - after.degraded if f[0] not in moved}
    changes = [removed, created, detached, attached, degraded, upgraded]
    if sum(len(c) for c in changes) != 1:
        return None
    if removed or created:
        (c,) = removed or created
        return ("remove" if removed else "create"), [("component", c)]
    if detached or attached:
        ((k, comp, port),) = detached or attached
        return ("detach" if detached else "attach"), [("connector", k), ("port", (comp, port))]
    (f,) = degraded or upgraded
    return ("degrade" if degraded else "upgrade"), [("functionality", f)]


def _plan_relations(configs: list[Any], states: list[str], comp_atoms: dict[str, str],
                    func_atoms: dict[Any, str], conn_atoms: dict[str, str], port_atoms: dict[Any, str],
                    rel: dict[str, list[str]], binary: bool = False) -> list[str]:
    """The configurations' relations (System -> ...) by what changes: what every state has
    is written once (`System -> x`), and each other element with the states that have it
    (`(S3 + S4) -> x`), elements with the same states grouped. A plan changes one element
    per step, so the text grows with the architecture plus the changes, not with their
    product. With `binary`, roles are `System -> Role` with `role_conn`/`role_port`, and
    the Role atoms are returned."""
    everywhere = "System"
    role_atoms: dict[tuple[str, str], str] = {}
    for key in ("comps", "degraded", "roles"):
        holders: dict[Any, list[int]] = {}
        for i, config in enumerate(configs):
            if key == "comps":
                items: Any = (comp_atoms[n] for n in config.components if n in comp_atoms)
            elif key == "degraded":
                items = (func_atoms[cf] for cf in config.degraded if cf in func_atoms)
            else:
                items = ((conn_atoms[k], port_atoms[c, p]) for k, c, p in config.roles
                         if k in conn_atoms and (c, p) in port_atoms)
            for item in items:
                holders.setdefault(item, []).append(i)
        by_states: dict[tuple[int, ...], list[Any]] = {}
        for item, indices in holders.items():
            by_states.setdefault(tuple(indices), []).append(item)
        for held, members in sorted(by_states.items(), key=lambda kv: (len(kv[0]), kv[0])):
            who = everywhere if len(held) == len(configs) else union([states[i] for i in held], "none")
            if key == "roles" and binary:
                for member in sorted(members):
                    role_atoms.setdefault(member, f"a_{len(role_atoms)}")
                body = union(sorted(role_atoms[m] for m in members), "none")
            elif key == "roles":
                per_conn: dict[str, list[str]] = {}
                for k, port in sorted(members):
                    per_conn.setdefault(k, []).append(port)
                body = union([f"{k} -> {union(ps, 'none')}" for k, ps in per_conn.items()], "none")
            else:
                body = union(sorted(members), "none")
            rel[key].append(f"{who} -> {body}")
    for (k, port), atom in role_atoms.items():
        rel["role_conn"].append(f"{atom} -> {k}")
        rel["role_port"].append(f"{atom} -> {port}")
    return list(role_atoms.values())


def _render(system: Any, configs: Sequence[Any], module_name: str, plan: bool,
            slice_: tuple[set[str], set[tuple[str, str]], set[str], SliceIndex] | None = None,
            serving: list[tuple[str, str]] | None = None, stable: list[str] | None = None,
            binary: bool = False, protocols: list[tuple[str, str]] | None = None,
            handover: list[tuple[str, str]] | None = None) -> tuple[str, dict[str, tuple[str, ...]]]:
    """An Alloy module for `system` (reconf_dsl.ir.System) in one or (plan) several
    configurations (checker.model.config.Configuration).

    Returns the text and a map from each atom name to what it stands for:
    ("component", c), ("port", c, p), ("functionality", c, f), ("connector", k),
    ("message", m), ("rate", hz), ("data", message, hz or ""), ("state", i).
    The module defines `valid`, `unsatisfied: Functionality -> Data` (evaluate it in the
    `Verdict` instance) and `check Valid` (a counterexample means the configuration is
    not valid).
    """
    from fractions import Fraction

    names: dict[str, tuple[str, ...]] = {}
    # a slice (see render_instance): the focus whole; of the other components only the
    # outputs attached to the connectors the focus reads, and the functionalities
    # behind them; only those connectors, all read through the configuration's index
    focus: set[str] | None = None
    context: set[tuple[str, str]] = set()
    index: SliceIndex | None = None
    if slice_ is not None:
        focus, context, read, index = slice_
        wanted = focus | {c for c, _ in context}
        comps = [index.components[n] for n in sorted(wanted & index.components.keys(), key=index.position.__getitem__)]
        configs = [index.view]
        connectors = [index.connectors[n][1] for n in sorted(read & index.connectors.keys(),
                                                             key=lambda n: index.connectors[n][0])]
    else:
        comps = _all_components(system)
        configs = [alloy_view(system, c) for c in configs]
        connectors = system.connectors

    # data predicates: one atom per distinct (message, rate)
    data_atoms: dict[tuple[str, Fraction | None], str] = {}
    messages: dict[str, str] = {}
    rates: set[Fraction] = set()

    def data(pred: Any) -> str:
        if pred is None or pred.message is None:
            return "Nothing"
        key = (pred.message, pred.hz)
        if key not in data_atoms:
            atom = f"d_{len(data_atoms)}"
            data_atoms[key] = atom
            names[atom] = ("data", pred.message, "" if pred.hz is None else str(pred.hz))
            if pred.message not in messages:
                messages[pred.message] = mangle("message", pred.message)
                names[messages[pred.message]] = ("message", pred.message)
            if pred.hz is not None:
                rates.add(pred.hz)
        return data_atoms[key]

    comp_atoms, port_atoms, func_atoms = {}, {}, {}
    inputs: list[str] = []
    outputs: list[str] = []
    # (functionality, output, meaning, normal datum, degraded datum) per guarantee
    guarantees: list[tuple[str, str, tuple[str, ...], str, str]] = []
    rel: dict[str, list[str]] = {k: [] for k in (
        "inputs", "outputs", "funcs", "iasm", "assoc_in", "assoc_out", "nasms", "gfunc",
        "gout", "gn", "gd", "nguar", "dguar", "cguar", "envg", "comps", "degraded", "roles", "role_conn", "role_port")}
    for c in comps:
        ca = comp_atoms[c.name] = mangle("component", c.name)
        names[ca] = ("component", c.name)
        judged = focus is None or c.name in focus
        for p in c.ports:
            if not judged and (p.kind == "input" or (c.name, p.name) not in context):
                continue
            pa = port_atoms[c.name, p.name] = mangle("port", c.name, p.name)
            names[pa] = ("port", c.name, p.name)
            if p.kind == "input":
                inputs.append(pa)
                rel["inputs"].append(f"{ca} -> {pa}")
                rel["iasm"].append(f"{pa} -> {data(p.assumption)}")
            else:
                outputs.append(pa)
                rel["outputs"].append(f"{ca} -> {pa}")
        for f in c.functionalities:
            if not judged and not any((c.name, pname) in port_atoms for pname in f.ports):
                continue
            fa = func_atoms[c.name, f.name] = mangle("functionality", c.name, f.name)
            names[fa] = ("functionality", c.name, f.name)
            rel["funcs"].append(f"{ca} -> {fa}")
            for pname in f.ports:
                port = c.port(pname)
                if port is None or (c.name, pname) not in port_atoms:
                    continue
                pa = port_atoms[c.name, pname]
                if port.kind == "input":
                    rel["assoc_in"].append(f"{fa} -> {pa}")
                else:
                    rel["assoc_out"].append(f"{fa} -> {pa}")
                    # written once the encoding is chosen (see `ternary` below)
                    normal, degraded = (data(m.guarantee(pname) if m is not None else None)
                                        for m in (f.normal, f.degraded))
                    guarantees.append((fa, pa, ("guarantee", c.name, f.name, pname), normal, degraded))
            if f.normal is not None and judged:
                for a in f.normal.assumptions:
                    rel["nasms"].append(f"{fa} -> {data(a)}")
    conn_atoms = {}
    for k in connectors:
        ka = conn_atoms[k.name] = mangle("connector", k.name)
        names[ka] = ("connector", k.name)
        rel["cguar"].append(f"{ka} -> {data(k.guarantee)}")
    for e in system.environment:
        rel["envg"].append(data(e.guarantee))
    # the configuration(s)
    states = [f"S{i}" for i in range(len(configs))]
    if plan:
        for i, state in enumerate(states):
            names[state] = ("state", str(i))
        roles = _plan_relations(configs, states, comp_atoms, func_atoms, conn_atoms, port_atoms, rel, binary)
    else:
        (config,) = configs
        # grouped (a connector -> a union of ports): fewer products for Alloy to type-check
        by_conn: dict[str, list[str]] = {}
        if index is not None:       # a slice: only its connectors, components and functionalities
            in_roles: Any = sorted({(k, c, p) for c in comp_atoms for k, p in index.roles_of.get(c, ())})
            in_comps: Any = sorted(n for n in comp_atoms if n in config.components)
            in_degraded: Any = sorted(cf for cf in func_atoms if cf in config.degraded)
        else:
            in_roles, in_comps, in_degraded = sorted(config.roles), sorted(config.components), sorted(config.degraded)
        for k, c, p in in_roles:
            if k in conn_atoms and (c, p) in port_atoms:
                by_conn.setdefault(conn_atoms[k], []).append(port_atoms[c, p])
        rel["comps"] += [comp_atoms[n] for n in in_comps if n in comp_atoms]
        rel["degraded"] += [func_atoms[cf] for cf in in_degraded if cf in func_atoms]
        rel["roles"] += [f"{k} -> {union(ps, 'none')}" for k, ps in by_conn.items()]

    rate_atoms = []
    for i, hz in enumerate(sorted(rates)):
        ra = f"r_{i}"
        rate_atoms.append((hz, ra))
        names[ra] = ("rate", str(hz))
    rate_of = dict(rate_atoms)
    mtype_rel, rate_rel = [], []
    for (msg, data_hz), atom in data_atoms.items():
        mtype_rel.append(f"{atom} -> {messages[msg]}")
        if data_hz is not None:
            rate_rel.append(f"{atom} -> {rate_of[data_hz]}")

    sigs: list[str] = []
    sigs += _one_sigs("MType", sorted(messages.values()))
    sigs += _one_sigs("Rate", [ra for _, ra in rate_atoms])
    sigs += ["abstract sig Data {}", "one sig Nothing extends Data {}"]
    sigs += _one_sigs("Msg", list(data_atoms.values()), "extends Data ")
    sigs += _one_sigs("Component", list(comp_atoms.values()))
    sigs += ["abstract sig Port {}"]
    sigs += _one_sigs("Input", inputs, "extends Port ")
    sigs += _one_sigs("Output", outputs, "extends Port ")
    sigs += _one_sigs("Functionality", list(func_atoms.values()))
    sigs += _one_sigs("Connector", list(conn_atoms.values()))
    # Guarantees as a ternary relation when the universe allows one (Functionality -> Output
    # -> Data, the meta-model's own encoding), else an atom each: the analyzer's symmetry
    # detection refines its partition once per one-sig atom, about quadratic in the atoms
    # (half of a module's fixed cost). A plan module with binary roles is past the limit.
    # (the analyzer's universe also holds Int atoms, 16 at the default bit width: leave room)
    ternary = not binary and (plan or len(names) + UNIVERSE_EXTRA <= TERNARY_ATOMS)
    guar_atoms: list[str] = []
    for fa, pa, meaning, normal, degraded in guarantees:
        if ternary:
            rel["nguar"].append(f"{fa} -> {pa} -> {normal}")
            rel["dguar"].append(f"{fa} -> {pa} -> {degraded}")
            continue
        ga = f"g_{len(guar_atoms)}"
        guar_atoms.append(ga)
        names[ga] = meaning
        rel["gfunc"].append(f"{ga} -> {fa}")
        rel["gout"].append(f"{ga} -> {pa}")
        rel["gn"].append(f"{ga} -> {normal}")
        rel["gd"].append(f"{ga} -> {degraded}")
    if not ternary:
        sigs += _one_sigs("Guar", guar_atoms)
    # an abstract sig without children could still hold atoms: forbid them
    parents: list[tuple[str, Any]] = [("MType", messages), ("Rate", rate_atoms), ("Msg", data_atoms),
                                      ("Component", comp_atoms), ("Input", inputs), ("Output", outputs),
                                      ("Functionality", func_atoms), ("Connector", conn_atoms)]
    for parent, children in parents + ([] if ternary else [("Guar", guar_atoms)]):
        if not children:
            sigs.append(f"fact no_{parent} {{ no {parent} }}")

    def grouped(pairs: list[str]) -> list[str]:
        """`a -> x` terms as `a -> (x + y + ...)`, one per distinct `a` (order kept)."""
        by_left: dict[str, list[str]] = {}
        for term in pairs:
            left, right = term.split(" -> ", 1)
            by_left.setdefault(left, []).append(right)
        return [f"{a} -> {union(rs, 'none')}" if len(rs) > 1 else f"{a} -> {rs[0]}" for a, rs in by_left.items()]

    for key in ("inputs", "outputs", "funcs", "assoc_in", "assoc_out", "nasms"):
        rel[key] = grouped(rel[key])
    funs = [
        ("rate_next", "Rate -> Rate", union([f"{a} -> {b}" for (_, a), (_, b) in zip(rate_atoms, rate_atoms[1:])],
                                            _empty("Rate", "Rate"))),
        ("mtype", "Msg -> MType", union(mtype_rel, _empty("Msg", "MType"))),
        ("rate", "Msg -> Rate", union(rate_rel, _empty("Msg", "Rate"))),
        ("inputs", "Component -> Input", union(rel["inputs"], _empty("Component", "Input"))),
        ("outputs", "Component -> Output", union(rel["outputs"], _empty("Component", "Output"))),
        ("funcs", "Component -> Functionality", union(rel["funcs"], _empty("Component", "Functionality"))),
        ("iasm", "Input -> Data", union(rel["iasm"], _empty("Input", "Data"))),
        ("assoc_in", "Functionality -> Input", union(rel["assoc_in"], _empty("Functionality", "Input"))),
        ("assoc_out", "Functionality -> Output", union(rel["assoc_out"], _empty("Functionality", "Output"))),
        ("nasms", "Functionality -> Data", union(rel["nasms"], _empty("Functionality", "Data"))),
    ] + ([
        ("nguar", "Functionality -> Output -> Data", union(rel["nguar"], _empty("Functionality", "Output", "Data"))),
        ("dguar", "Functionality -> Output -> Data", union(rel["dguar"], _empty("Functionality", "Output", "Data"))),
    ] if ternary else [
        ("gfunc", "Guar -> Functionality", union(rel["gfunc"], _empty("Guar", "Functionality"))),
        ("gout", "Guar -> Output", union(rel["gout"], _empty("Guar", "Output"))),
        ("gn", "Guar -> Data", union(rel["gn"], _empty("Guar", "Data"))),
        ("gd", "Guar -> Data", union(rel["gd"], _empty("Guar", "Data"))),
    ]) + [
        ("cguar", "Connector -> Data", union(rel["cguar"], _empty("Connector", "Data"))),
        ("envg", "set Data", union(sorted(set(rel["envg"])), "(Data - Data)")),
    ]
    if plan:
        funs += [
            ("comps", "System -> Component", union(rel["comps"], _empty("System", "Component"))),
            ("degraded", "System -> Functionality", union(rel["degraded"], _empty("System", "Functionality"))),
        ]
        if binary:
            funs += [
                ("sroles", "System -> Role", union(rel["roles"], _empty("System", "Role"))),
                ("role_conn", "Role -> Connector", union(rel["role_conn"], _empty("Role", "Connector"))),
                ("role_port", "Role -> Port", union(rel["role_port"], _empty("Role", "Port"))),
            ]
            sigs += _one_sigs("Role", roles) + ([] if roles else ["fact no_Role { no Role }"])
        else:
            funs.append(("roles", "System -> Connector -> Port",
                         union(rel["roles"], _empty("System", "Connector", "Port"))))
        template = environment().get_template("plan.als.j2")
        terms = []
        step_calls = []
        for i, (before, after) in enumerate(zip(configs, configs[1:])):
            step = step_action(before, after)
            if step is None:
                step_calls.append("some none")
                continue
            action, args = step
            atoms = {"component": comp_atoms, "connector": conn_atoms}
            alloy_args = []
            for kind, value in args:
                if kind == "port":
                    alloy_args.append(port_atoms[value])
                elif kind == "functionality":
                    alloy_args.append(func_atoms[value])
                else:
                    alloy_args.append(atoms[kind][value])
            s, s2 = states[i], states[i + 1]
            call = f"{action}[{s}, {s2}, {', '.join(alloy_args)}]"
            step_calls.append(call)
            terms.append(f"({{s: {s} | {call}}} -> {action.capitalize()})")
        ok_steps = union(terms, _empty("System", "Action"))
        watch = None
        serving, handover = serving or [], handover or []
        if serving or handover:
            proxies = [func_atoms[c, f.name] for _, c in serving for comp in comps if comp.name == c
                       for f in comp.functionalities if (c, f.name) in func_atoms]
            conns = [conn_atoms[k] for k, _ in serving if k in conn_atoms]
            handed = [conn_atoms[k] for k, _ in handover if k in conn_atoms]
            if len(conns) != len(serving) or (serving and not proxies) or len(handed) != len(handover) \
                    or any(c not in comp_atoms for _, c in handover):
                raise ValueError(f"serving names what the architecture lacks: {serving + handover}")
            watch = {"proxies": union(proxies, "none"), "connectors": union(conns, "none"), "protocols": "",
                     "handing": union(sorted({comp_atoms[c] for _, c in handover}), "none"),
                     "handed": union(handed, "none")}
            if protocols or handover:
                # the proxies' requests must reach one of these (present) protocols
                watch["proxy_comps"] = union(sorted({comp_atoms[c] for _, c in serving}), "none")
                watch["protocols"] = union(sorted(f"{comp_atoms[x]} -> {comp_atoms[p]}" for x, p in protocols or []
                                                  if x in comp_atoms and p in comp_atoms), _empty("Component", "Component"))
        kept = None
        if stable:
            missing = [k for k in stable if k not in conn_atoms]
            if missing:
                raise ValueError(f"stable names connectors the architecture lacks: {missing}")
            kept = union([conn_atoms[k] for k in stable], "none")
        text = template.render(st=PLAN_BINARY_STATE if binary else PLAN_CONST_STATE, sigs=sigs, funs=funs, module_name=module_name,
                               system_name=system.name, states=states, ok_steps=ok_steps, serving=watch,
                               stable=kept, step_calls=step_calls)
        return text, names
    funs += [
        ("comps", "set Component", union(rel["comps"], "none")),
        ("degraded", "set Functionality", union(rel["degraded"], "none")),
        ("roles", "Connector -> Port", union(rel["roles"], _empty("Connector", "Port"))),
    ]
    template = environment().get_template("instance.als.j2")
    text = template.render(st=FIXED_TERNARY_STATE if ternary else FIXED_STATE, sigs=sigs, funs=funs,
                           module_name=module_name, system_name=system.name)
    return text, names


if __name__ == "__main__":
    sys.exit(main())
