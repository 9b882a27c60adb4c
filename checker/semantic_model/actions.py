"""The six reconfiguration actions of paper 001 §4.3 and their preconditions.

Each action takes a valid configuration to a valid one when its preconditions hold
(docs/design.md#the-six-actions). `preconditions` returns the failing ones in words, `apply`
performs an action or raises `ActionRefused`.

Each action is defined here once: its class (fields, name, symbol), its precondition, its
effect, and its entry in `KINDS` (`checker.semantic_model.action_kinds.ActionKind`), which also says how it
shows in the difference between two configurations (`recognise`) and how Alloy names its
arguments. Everything else, the Alloy modules and the Alloy planner included, reads it there.

Two points where the paper's model is narrower than ours, and what is done about it:

- A port may be attached to several connectors. "Safe without input i" (`safe_no_input`)
  therefore means: safe when i is no longer satisfied *through the detached connector(s)*;
  i may still be satisfied through another one. In the paper's model, where a port has one
  connector, this is exactly the paper's predicate.
- Degrading f: the paper asks every component, f included, to be safe without the inputs
  of the connectors that become unsatisfied. f itself is exempt here, since its degraded
  mode assumes nothing (rule ii); otherwise a functionality reading its own output could
  never be degraded.

Extension (docs/design.md#where-reconf-departs-from-paper-001): attaching a second publisher to
a `single` topic or to a service is refused. Upgrading is refused when it would break a
connector, which can only happen when rule (iii) on modes is violated.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar, Iterable, Optional, TypeVar, Union, cast

from checker.semantic_model.action_kinds import ActionKind, Change, Kind
from checker.semantic_model.config import Configuration, FuncId, Role
from checker.semantic_model.rules import BY_NAME as RULE_NAMES
from checker.semantic_model.rules import Refusal
from reconf_dsl.ir import Component, Connector, Functionality, Mode, Port, Predicate, System
from reconf_dsl.ir import satisfies as _satisfies

__all__ = ["Remove", "Create", "Detach", "Attach", "Degrade", "Upgrade", "Action", "ActionRefused",
           "preconditions", "check", "Snapshot", "catalogue", "affected_connectors", "apply", "effect",
           "action_from_dict", "is_valid", "failing_assumptions", "KINDS", "refusals", "unknown_name", "step_refusals",
           "state_refusals", "form_refusals", "kind_of", "changes", "recognise"]


@dataclass(frozen=True)
class ActionBase:
    """What every action has: its name `kind` and its `symbol` (as plans print them), and
    its fields, which are its dictionary form besides the name (`to_dict`)."""

    kind: ClassVar[str]
    symbol: ClassVar[str]

    def to_dict(self) -> dict[str, str]:
        return {"action": self.kind, **{f.name: str(getattr(self, f.name)) for f in fields(self)}}


@dataclass(frozen=True)
class Remove(ActionBase):
    component: str
    kind: ClassVar[str] = "remove"
    symbol: ClassVar[str] = "-"

    def describe(self) -> str:
        return f"remove {self.component}"


@dataclass(frozen=True)
class Create(ActionBase):
    component: str
    kind: ClassVar[str] = "create"
    symbol: ClassVar[str] = "+"

    def describe(self) -> str:
        return f"create {self.component} (all functionalities degraded)"


@dataclass(frozen=True)
class Detach(ActionBase):
    connector: str
    component: str
    port: str
    kind: ClassVar[str] = "detach"
    symbol: ClassVar[str] = "×"

    def describe(self) -> str:
        return f"detach {self.component}.{self.port} from {self.connector}"


@dataclass(frozen=True)
class Attach(ActionBase):
    connector: str
    component: str
    port: str
    kind: ClassVar[str] = "attach"
    symbol: ClassVar[str] = "→"

    def describe(self) -> str:
        return f"attach {self.component}.{self.port} to {self.connector}"


@dataclass(frozen=True)
class Degrade(ActionBase):
    component: str
    functionality: str
    kind: ClassVar[str] = "degrade"
    symbol: ClassVar[str] = "↓"

    def describe(self) -> str:
        return f"degrade {self.component}.{self.functionality}"


@dataclass(frozen=True)
class Upgrade(ActionBase):
    component: str
    functionality: str
    kind: ClassVar[str] = "upgrade"
    symbol: ClassVar[str] = "↑"

    def describe(self) -> str:
        return f"upgrade {self.component}.{self.functionality}"


Action = Union[Remove, Create, Detach, Attach, Degrade, Upgrade]


def action_from_dict(d: dict[str, str]) -> Action:
    """The inverse of `to_dict`."""
    # the registry holds the Action classes only
    return cast(Action, _BY_NAME[d["action"]].make({k: v for k, v in d.items() if k != "action"}))


class ActionRefused(Exception):
    def __init__(self, action: Action, reasons: list[str]) -> None:
        super().__init__(f"cannot {action.describe()}: " + "; ".join(reasons))
        self.action = action
        self.reasons = reasons


# --- satisfaction, fast and with exclusions (the paper's *_no_* predicates) -------------

_SAT: dict[tuple[int, int], tuple[Predicate, Predicate, bool]] = {}


def satisfies(p: Predicate, q: Predicate) -> bool:
    """`reconf_dsl.ir.satisfies`, memoised by identity: planners ask the same question very often
    about the same IR objects, and hashing predicates (with their Fractions) costs more than
    the answer. The entry keeps p and q alive, so their ids cannot be reused meanwhile."""
    key = (id(p), id(q))
    hit = _SAT.get(key)
    if hit is not None and hit[0] is p and hit[1] is q:
        return hit[2]
    if len(_SAT) > 1 << 18:
        _SAT.clear()
    sat = _satisfies(p, q)
    _SAT[key] = (p, q, sat)
    return sat


ROOM = 500_000
"""Entries (connectors and ports, per index) the caches of a `_Catalogue` hold at most, beyond
16 indexes: each index is about 40 bytes an entry, so about 80 MB whatever the system's size."""


class _Catalogue:
    """What the actions need to know about a System, indexed once."""

    def __init__(self, system: System) -> None:
        self.system = system
        self.comps: dict[str, Component] = {c.name: c for c in system.components + system.versions}
        self.conns: dict[str, Connector] = {c.name: c for c in system.connectors}
        self.env: list[Predicate] = [e.guarantee for e in system.environment]
        self.funcs: dict[FuncId, Functionality] = {
            (c.name, f.name): f for c in self.comps.values() for f in c.functionalities}
        self.ports: dict[tuple[str, str], Port] = {(c.name, p.name): p for c in self.comps.values() for p in c.ports}
        self._index: dict[tuple[frozenset[str], frozenset[Role]], _Index] = {}
        # The same indexes by identity of the two sets: an action's effect derives the next
        # configuration's index from the current one, so a plan step costs its own size only.
        self._ident: dict[tuple[int, int], tuple[frozenset[str], frozenset[Role], _Index]] = {}
        self._room = max(16, min(256, ROOM // (len(system.connectors) + len(self.ports) + 1)))

    def is_output(self, comp: str, port: str) -> bool:
        p = self.ports.get((comp, port))
        return p is not None and p.kind == "output"

    def index(self, config: Configuration) -> "_Index":
        """Who is attached where in `config`, cached: consecutive states often share their sets."""
        comps, roles = config.components, config.roles
        hit = self._ident.get((id(comps), id(roles)))
        if hit is not None and hit[0] is comps and hit[1] is roles:
            return hit[2]
        key = (comps, roles)
        ix = self._index.get(key)
        if ix is None:
            ix = _Index.build(self, config)
            self._store(config, ix)
        else:
            self._remember(config, ix)
        return ix

    def _remember(self, config: Configuration, ix: "_Index") -> None:
        if len(self._ident) > self._room:
            self._ident.clear()
        self._ident[(id(config.components), id(config.roles))] = (config.components, config.roles, ix)

    def _store(self, config: Configuration, ix: "_Index") -> None:
        if len(self._index) > self._room:
            self._index.clear()
        self._index[(config.components, config.roles)] = ix
        self._remember(config, ix)

    def derive(self, before: Configuration, after: Configuration, action: "Action") -> None:
        """Index `after` from the index of `before` when `action` changes attachments or removes."""
        if isinstance(action, (Attach, Detach)):
            role = (action.connector, action.component, action.port)
            if ((role in before.roles) == isinstance(action, Attach) or action.component not in before.components
                    or action.connector not in self.conns or (action.component, action.port) not in self.ports):
                ix = self.index(before)
            else:
                ix = self.index(before).changed(self, [role], isinstance(action, Attach))
        elif isinstance(action, Remove):
            ix = self.index(before)
            if action.component in before.components:
                gone = [(conn, action.component, p.name) for p in self.comps[action.component].ports
                        for conn in ix.by_port.get((action.component, p.name), [])]
                if gone:
                    ix = ix.changed(self, gone, False)
        else:
            return
        self._store(after, ix)


class _Index:
    def __init__(self, by_conn: dict[str, list[tuple[str, str]]], by_port: dict[tuple[str, str], list[str]],
                 pubs: dict[str, list[tuple[str, str]]], subs: dict[str, list[tuple[str, str]]]) -> None:
        self.by_conn = by_conn      # every attached (component, port), per connector
        self.by_port = by_port      # the connectors of each attached port
        self.pubs = pubs            # the attached outputs, per connector
        self.subs = subs            # the attached inputs, per connector

    @staticmethod
    def build(cat: _Catalogue, config: Configuration) -> "_Index":
        by_conn: dict[str, list[tuple[str, str]]] = {}
        by_port: dict[tuple[str, str], list[str]] = {}
        pubs: dict[str, list[tuple[str, str]]] = {}
        subs: dict[str, list[tuple[str, str]]] = {}
        comps, conns, ports = config.components, cat.conns, cat.ports
        for conn, comp, port in config.roles:
            if comp in comps and conn in conns and (comp, port) in ports:
                by_conn.setdefault(conn, []).append((comp, port))
                by_port.setdefault((comp, port), []).append(conn)
                (pubs if ports[(comp, port)].kind == "output" else subs).setdefault(conn, []).append((comp, port))
        return _Index(by_conn, by_port, pubs, subs)

    def changed(self, cat: _Catalogue, roles: list[Role], add: bool) -> "_Index":
        """A copy with `roles` (indexed ones, all absent if `add`, all present otherwise) added or removed."""
        by_conn, by_port, pubs, subs = dict(self.by_conn), dict(self.by_port), dict(self.pubs), dict(self.subs)
        for conn, comp, port in roles:
            side = pubs if cat.ports[(comp, port)].kind == "output" else subs
            if add:
                by_conn[conn] = by_conn.get(conn, []) + [(comp, port)]
                by_port[(comp, port)] = by_port.get((comp, port), []) + [conn]
                side[conn] = side.get(conn, []) + [(comp, port)]
                continue
            _drop(by_conn, conn, (comp, port))
            _drop(by_port, (comp, port), conn)
            _drop(side, conn, (comp, port))
        return _Index(by_conn, by_port, pubs, subs)


_K = TypeVar("_K")
_V = TypeVar("_V")


def _drop(d: dict[_K, list[_V]], key: _K, value: _V) -> None:
    rest = [x for x in d[key] if x != value]
    if rest:
        d[key] = rest
    else:
        del d[key]


_CACHE: dict[int, _Catalogue] = {}


def catalogue(system: System) -> _Catalogue:
    cat = _CACHE.get(id(system))
    if cat is None or cat.system is not system:
        if len(_CACHE) > 64:
            _CACHE.clear()
        cat = _CACHE[id(system)] = _Catalogue(system)
    return cat


def _mode(f: Functionality, comp: str, config: Configuration, degraded: Optional[FuncId] = None) -> Mode:
    mode = f.degraded if (comp, f.name) in config.degraded or (comp, f.name) == degraded else f.normal
    assert mode is not None, "resolved IR has both modes"
    return mode


class Snapshot:
    """Satisfaction in one configuration, with ports or connectors optionally left out."""

    def __init__(self, cat: _Catalogue, config: Configuration) -> None:
        self.cat = cat
        self.config = config
        ix = cat.index(config)
        self.by_conn = ix.by_conn
        self.by_port = ix.by_port
        self.pubs = ix.pubs
        self.subs = ix.subs
        self._conn_cache: dict[str, bool] = {}

    def is_output(self, comp: str, port: str) -> bool:
        return self.cat.is_output(comp, port)

    def attached_outputs(self, comp: str) -> list[tuple[str, str]]:
        """(connector, output port) of every output of `comp` attached in this configuration."""
        c = self.cat.comps.get(comp)
        return [(conn, p.name) for p in (c.ports if c is not None else ()) if p.kind == "output"
                for conn in self.by_port.get((comp, p.name), ())]

    def readers(self, conns: Iterable[str]) -> set[str]:
        """The present components with an input attached to one of `conns`."""
        subs = self.subs
        return {c for conn in conns for c, _ in subs.get(conn, ())}

    def output_satisfies(self, comp: str, port: str, want: Predicate) -> bool:
        c = self.cat.comps[comp]
        return any(port in f.ports and satisfies(_mode(f, comp, self.config).guarantee(port), want)
                   for f in c.functionalities)

    def conn_sat(self, conn: str, no_out: Iterable[tuple[str, str]] = ()) -> bool:
        excluded = set(no_out)
        if not excluded and conn in self._conn_cache:
            return self._conn_cache[conn]
        want = self.cat.conns[conn].guarantee
        sat = any(self.output_satisfies(c, p, want) for c, p in self.pubs.get(conn, ()) if (c, p) not in excluded)
        if not excluded:
            self._conn_cache[conn] = sat
        return sat

    def input_sat(self, comp: str, port: str, dead: frozenset[str] = frozenset(),
                  dead_role: Optional[Role] = None) -> bool:
        asm = self.cat.ports.get((comp, port))
        if asm is None or asm.assumption is None:
            return False
        for conn in self.by_port.get((comp, port), []):
            if conn in dead or (conn, comp, port) == dead_role:
                continue
            if self.conn_sat(conn) and satisfies(self.cat.conns[conn].guarantee, asm.assumption):
                return True
        return False

    def holds(self, comp: str, f: Functionality, a: Predicate, dead: frozenset[str] = frozenset(),
              dead_role: Optional[Role] = None) -> bool:
        ports = self.cat.ports
        for pname in f.ports:
            p = ports.get((comp, pname))
            if p is None or p.kind != "input" or p.assumption is None:
                continue
            if satisfies(p.assumption, a) and self.input_sat(comp, pname, dead, dead_role):
                return True
        return any(satisfies(e, a) for e in self.cat.env)

    def unsafe(self, comps: Iterable[str], dead: frozenset[str] = frozenset(), dead_role: Optional[Role] = None,
               exempt: Optional[FuncId] = None) -> list[tuple[str, str, Predicate]]:
        """`safe_no_input`, negated: the current assumptions that fail once the given inputs are gone."""
        out = []
        for comp in sorted(comps):
            for f in self.cat.comps[comp].functionalities:
                if (comp, f.name) == exempt:
                    continue
                for a in _mode(f, comp, self.config).assumptions:
                    if not self.holds(comp, f, a, dead, dead_role):
                        out.append((comp, f.name, a))
        return out


def failing_assumptions(system: System, config: Configuration) -> list[tuple[str, str, Predicate]]:
    """Every (component, functionality, assumption) of the current modes that does not hold."""
    cat = catalogue(system)
    return Snapshot(cat, config).unsafe(c for c in config.components if c in cat.comps)


def state_refusals(system: System, config: Configuration) -> list[Refusal]:
    """The rules about a configuration (`checker.semantic_model.rules`, `state.*`) that `config`
    breaks: well-formedness (`form_refusals`) and validity. Raises ValueError when an
    attachment names what the architecture does not declare."""
    out = form_refusals(system, config)
    out += [_no("state.valid", f"{c}.{f} assumes {a}, which does not hold") for c, f, a in failing_assumptions(system, config)]
    return out


def form_refusals(system: System, config: Configuration) -> list[Refusal]:
    """The rules of well-formedness `config` breaks: one publisher on a `single` topic, one
    server on a service, each attachment well typed and of a present component. Raises
    ValueError when an attachment names what the architecture does not declare."""
    cat = catalogue(system)
    out: list[Refusal] = []
    pubs: dict[str, list[str]] = {}
    for conn, comp, port in sorted(config.roles):
        k, p = cat.conns.get(conn), cat.ports.get((comp, port))
        if k is None or p is None:
            raise ValueError(f"{comp}.{port} on {conn}: " + ("no such connector" if k is None else "no such port"))
        who = f"{comp}.{port}"
        if comp not in config.components:
            out.append(_no("state.owned", f"{who} is attached to {conn}, but {comp} is not in the system"))
        if k.guarantee.message is not None and p.message != k.guarantee.message:
            out.append(_no("state.typed", f"{who} carries {p.message}, but {conn} carries {k.guarantee.message}"))
        if p.kind == "output":
            pubs.setdefault(conn, []).append(who)
    for conn, names in sorted(pubs.items()):
        k = cat.conns[conn]
        if len(names) > 1 and k.kind == "service":
            out.append(_no("state.service", f"{conn} is a service with {len(names)} servers: {', '.join(names)}"))
        elif len(names) > 1 and k.single:
            out.append(_no("state.single", f"{conn} takes a single publisher and has {len(names)}: "
                                           f"{', '.join(names)}"))
    return out


def is_valid(system: System, config: Configuration) -> bool:
    """The safety property (same verdict as `semantics.evaluate(...).valid`, faster)."""
    return not failing_assumptions(system, config)


# --- preconditions ---------------------------------------------------------------------

def preconditions(system: System, config: Configuration, action: Action) -> list[str]:
    """The preconditions of `action` (paper 001 §4.3) that fail in `config`, in words; [] when it may run."""
    return check(Snapshot(catalogue(system), config), action)


def check(st: Snapshot, action: Action) -> list[str]:
    """`preconditions` on a snapshot, so one snapshot serves many candidate actions. An
    action naming what the architecture does not declare is refused for that alone."""
    unknown = unknown_name(st.cat, action)
    if unknown is not None:
        return [unknown]
    return [r.text for r in kind_of(action).preconditions(st, action)]


def refusals(system: System, config: Configuration, action: Action) -> list[Refusal]:
    """The preconditions of `action` that fail in `config`, each with its rule's name
    (`checker.semantic_model.rules`). Raises ValueError when the action names what the architecture
    does not declare (`unknown_name`): that is no rule of a step, but a step that is not one."""
    cat = catalogue(system)
    unknown = unknown_name(cat, action)
    if unknown is not None:
        raise ValueError(unknown)
    return kind_of(action).preconditions(Snapshot(cat, config), action)


def step_refusals(system: System, before: Configuration, action: Action, after: Configuration) -> list[Refusal]:
    """The rules (`checker.semantic_model.rules`) a step from `before` by `action` to `after` breaks:
    its preconditions in `before`, and `<action>.effect` when `after` is not the action's
    effect (the modes of absent components aside: neither engine reads them). Raises
    ValueError as `refusals` does."""
    out = refusals(system, before, action)
    expected = _settled(effect(system, before, action))
    got = _settled(after)
    if got != expected:
        diff = [f"{'has' if extra else 'lacks'} {what}" for part, (want, have) in zip(("component", "degraded", "role"),
                                                                                     zip(expected, got))
                for extra, items in ((True, have - want), (False, want - have)) for what in
                (f"{part} {'.'.join(x) if isinstance(x, tuple) else x}" for x in sorted(items, key=str))]
        out.append(_no(f"{action.kind}.effect", f"the configuration after {action.describe()} is not its effect: "
                                                f"it {', '.join(diff[:4])}{', …' if len(diff) > 4 else ''}"))
    return out


def _settled(c: Configuration) -> tuple[frozenset[Any], frozenset[Any], frozenset[Any]]:
    """What both engines read of a configuration: the modes of present components only."""
    return c.components, frozenset(d for d in c.degraded if d[0] in c.components), c.roles


def unknown_name(cat: _Catalogue, action: Action) -> Optional[str]:
    """What `action` names that the architecture does not declare, in words, or None."""
    comp = cat.comps.get(action.component)
    if comp is None:
        return f"no component {action.component} is declared"
    if isinstance(action, (Attach, Detach)):
        if action.connector not in cat.conns:
            return f"{action.connector} is not a connector of the system"
        if comp.port(action.port) is None:
            return f"{action.component} has no port {action.port}"
    if isinstance(action, (Degrade, Upgrade)) and (action.component, action.functionality) not in cat.funcs:
        return f"{action.component} has no functionality {action.functionality}"
    return None


def _no(rule: str, text: str) -> Refusal:
    assert rule in RULE_NAMES, rule
    return Refusal(rule, text)


def _remove(st: Snapshot, a: Remove) -> list[Refusal]:
    if a.component not in st.config.components:
        return [_no("remove.present", f"{a.component} is not in the system")]
    return [_no("remove.isolated", f"{a.component} is not isolated: {a.component}.{p} is attached to {conn}")
            for conn, comp, p in sorted(st.config.roles) if comp == a.component]


def _create(st: Snapshot, a: Create) -> list[Refusal]:
    c = st.cat.comps[a.component]
    if a.component in st.config.components:
        return [_no("create.absent", f"{a.component} is already in the system")]
    return [_no("create.degraded", f"{a.component}.{f.name} has no degraded mode, so {a.component} cannot be "
                                   "created degraded") for f in c.functionalities if f.degraded is None]


def _port_problems(st: Snapshot, a: Union[Detach, Attach]) -> list[Refusal]:
    attached = (a.connector, a.component, a.port) in st.config.roles
    if isinstance(a, Detach) and not attached:
        return [_no("detach.attached", f"{a.component}.{a.port} is not attached to {a.connector}")]
    if isinstance(a, Attach) and attached:
        return [_no("attach.detached", f"{a.component}.{a.port} is already attached to {a.connector}")]
    if a.component not in st.config.components:
        return [_no(f"{a.kind}.present", f"{a.component}.{a.port} is not a port of a present component "
                                         f"({a.component} is not in the system)")]
    return []


def _detach(st: Snapshot, a: Detach) -> list[Refusal]:
    where = _port_problems(st, a)
    if where:
        return where
    who = f"{a.component}.{a.port}"
    if not st.is_output(a.component, a.port):
        return [_no("detach.input", f"{c}.{f} is not safe without input {who}: it assumes {asm}, which no other "
                                    "satisfied input or environment guarantee provides (safe_no_input)")
                for c, f, asm in st.unsafe([a.component], dead_role=(a.connector, a.component, a.port))]
    if st.conn_sat(a.connector, [(a.component, a.port)]):
        return []
    return [_no("detach.output", f"no other output satisfies {a.connector} without {who}, and {c}.{f} is not safe "
                                 f"without the inputs of {a.connector}: it assumes {asm} (safe_no_input)")
            for c, f, asm in st.unsafe(st.readers([a.connector]), dead=frozenset([a.connector]))]


def _attach(st: Snapshot, a: Attach) -> list[Refusal]:
    where = _port_problems(st, a)
    if where:
        return where
    conn = st.cat.conns[a.connector]
    port = st.cat.ports[(a.component, a.port)]
    who = f"{a.component}.{a.port}"
    if port.kind == "input":
        assert port.assumption is not None
        if satisfies(conn.guarantee, port.assumption):
            return []
        return [_no("attach.input", f"{a.connector} guarantees {conn.guarantee}, which does not satisfy the "
                                    f"assumption {port.assumption} of input {who}")]
    problems = []
    if not st.output_satisfies(a.component, a.port, conn.guarantee):
        now = [str(_mode(f, a.component, st.config).guarantee(a.port))
               for f in st.cat.comps[a.component].functionalities if a.port in f.ports] or ["nothing"]
        problems.append(_no("attach.output", f"the current guarantee of {who} ({', '.join(now)}) does not satisfy "
                                             f"the guarantee {conn.guarantee} of {a.connector}"))
    others = [f"{c}.{p}" for c, p in sorted(st.pubs.get(a.connector, []))]
    if others and conn.kind == "service":
        problems.append(_no("attach.service", f"{a.connector} is a service and already has a server: "
                                              f"{', '.join(others)}"))
    elif others and conn.single:
        problems.append(_no("attach.single", f"{a.connector} takes a single publisher and already has "
                                             f"{', '.join(others)}"))
    return problems


def _functionality(st: Snapshot, a: Union[Degrade, Upgrade]) -> tuple[list[Refusal], Functionality]:
    """The functionality `a` names, and whether its component is present."""
    f = st.cat.funcs[(a.component, a.functionality)]
    if a.component not in st.config.components:
        return [_no(f"{a.kind}.present", f"{a.component} is not in the system")], f
    return [], f


def _degrade(st: Snapshot, a: Degrade) -> list[Refusal]:
    problems, f = _functionality(st, a)
    if problems:
        return problems
    fid = (a.component, a.functionality)
    who = f"{a.component}.{a.functionality}"
    if fid in st.config.degraded:
        return [_no("degrade.normal", f"{who} is already degraded")]
    dead = frozenset(affected_connectors(st, a.component, f))
    return [_no("degrade.safe", f"degrading {who} leaves {', '.join(sorted(dead))} unsatisfied, and {c}.{g} is not "
                                f"safe without their inputs: it assumes {asm} (safe_no_input)")
            for c, g, asm in st.unsafe(st.readers(dead), dead=dead, exempt=fid)]


def _upgrade(st: Snapshot, a: Upgrade) -> list[Refusal]:
    problems, f = _functionality(st, a)
    if problems:
        return problems
    fid = (a.component, a.functionality)
    who = f"{a.component}.{a.functionality}"
    if fid not in st.config.degraded:
        return [_no("upgrade.degraded", f"{who} is not degraded")]
    assert f.normal is not None
    problems = [_no("upgrade.assumptions", f"the normal mode of {who} assumes {asm}, which does not hold now")
                for asm in f.normal.assumptions if not st.holds(a.component, f, asm)]
    return problems + _upgrade_connectors(st, a.component, f)


def _upgrade_connectors(st: Snapshot, comp: str, f: Functionality) -> list[Refusal]:
    """The connectors upgrading f would break: satisfied now, and by no other output, nor
    by this one once f is normal (another functionality of the port may still satisfy it)."""
    assert f.normal is not None
    problems = []
    for port, conn in sorted((port, conn) for port in f.ports for conn in st.by_port.get((comp, port), [])):
        if st.is_output(comp, port):
            want = st.cat.conns[conn].guarantee
            after = [satisfies(_mode(g, comp, st.config).guarantee(port) if g is not f else f.normal.guarantee(port),
                               want) for g in st.cat.comps[comp].functionalities if port in g.ports]
            if not any(after) and st.conn_sat(conn) and not st.conn_sat(conn, [(comp, port)]):
                problems.append(_no("upgrade.connectors", f"the normal guarantee of {comp}.{port} does not satisfy "
                                                          f"{conn}, which only its degraded guarantee satisfies (rule "
                                                          "iii on modes is violated)"))
    return problems


def affected_connectors(st: Snapshot, comp: str, f: Functionality) -> list[str]:
    """AffectedConns(f) of Algorithm 1: connectors left unsatisfied when f is degraded."""
    outs = [(comp, p) for p in f.ports if st.is_output(comp, p)]
    assert f.degraded is not None
    out = []
    for conn in sorted({conn for o in outs for conn in st.by_port.get(o, [])}):
        if st.conn_sat(conn, outs):
            continue
        if any((c, p) in st.by_conn.get(conn, []) and satisfies(f.degraded.guarantee(p), st.cat.conns[conn].guarantee)
               for c, p in outs):
            continue
        out.append(conn)
    return out


# --- effects ---------------------------------------------------------------------------

def effect(system: System, config: Configuration, action: Action) -> Configuration:
    """The configuration after `action`, preconditions not checked."""
    after = _effect(system, config, action)
    if isinstance(action, (Attach, Detach, Remove)):
        catalogue(system).derive(config, after, action)
    return after


def _effect(system: System, config: Configuration, action: Action) -> Configuration:
    return kind_of(action).after(catalogue(system), config, action)


def _after_remove(cat: _Catalogue, config: Configuration, a: Remove) -> Configuration:
    return Configuration(config.components - {a.component},
                         frozenset(d for d in config.degraded if d[0] != a.component), config.roles)


def _after_create(cat: _Catalogue, config: Configuration, a: Create) -> Configuration:
    comp = cat.comps[a.component]
    return Configuration(config.components | {a.component},
                         config.degraded | {(comp.name, f.name) for f in comp.functionalities}, config.roles)


def _after_detach(cat: _Catalogue, config: Configuration, a: Detach) -> Configuration:
    return Configuration(config.components, config.degraded, config.roles - {(a.connector, a.component, a.port)})


def _after_attach(cat: _Catalogue, config: Configuration, a: Attach) -> Configuration:
    return Configuration(config.components, config.degraded, config.roles | {(a.connector, a.component, a.port)})


def _after_degrade(cat: _Catalogue, config: Configuration, a: Degrade) -> Configuration:
    return Configuration(config.components, config.degraded | {(a.component, a.functionality)}, config.roles)


def _after_upgrade(cat: _Catalogue, config: Configuration, a: Upgrade) -> Configuration:
    return Configuration(config.components, config.degraded - {(a.component, a.functionality)}, config.roles)


def apply(system: System, config: Configuration, action: Action) -> Configuration:
    """Perform `action`; raises ActionRefused with the failing preconditions."""
    reasons = preconditions(system, config, action)
    if reasons:
        raise ActionRefused(action, reasons)
    return effect(system, config, action)


# --- the registry ----------------------------------------------------------------------

KINDS: tuple[Kind, ...] = (
    ActionKind[Remove](cls=Remove, precondition=_remove, effect=_after_remove, change_field="removed",
                       params=("component",), seconds=0.03),
    ActionKind[Create](cls=Create, precondition=_create, effect=_after_create, change_field="created",
                       params=("component",), seconds=0.11),
    ActionKind[Detach](cls=Detach, precondition=_detach, effect=_after_detach, change_field="detached",
                       params=("connector", "port"), seconds=0.01),
    ActionKind[Attach](cls=Attach, precondition=_attach, effect=_after_attach, change_field="attached",
                       params=("connector", "port"), seconds=0.06),
    ActionKind[Degrade](cls=Degrade, precondition=_degrade, effect=_after_degrade, change_field="degraded",
                        params=("functionality",), seconds=0.01),
    ActionKind[Upgrade](cls=Upgrade, precondition=_upgrade, effect=_after_upgrade, change_field="upgraded",
                        params=("functionality",), seconds=0.03),
)
"""Every action, in the order the Alloy modules declare them."""

_BY_NAME: dict[str, Kind] = {k.name: k for k in KINDS}


def kind_of(action: Action) -> Kind:
    """The registry's entry for `action`."""
    return _BY_NAME[action.kind]


def changes(before: Configuration, after: Configuration) -> list[Action]:
    """The single actions the difference from `before` to `after` is made of, kind by kind."""
    change = Change.between(before, after)
    return [a for kind in KINDS for a in kind.found(change)]


def recognise(before: Configuration, after: Configuration) -> Optional[Action]:
    """The one action that takes `before` to `after`, or None when the difference is not one action."""
    found = changes(before, after)
    return found[0] if len(found) == 1 else None
