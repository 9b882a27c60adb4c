"""`reconf verify-meta-model --unbounded`: the six `Safe<Action>` assertions of the meta-model, and
`AbsentDegraded`, proved with z3 for configurations of every size, finite or infinite.

Each assertion reads "valid(Pre) and action(Pre, Post) implies valid(Post)" over uninterpreted
sorts and an arbitrary satisfaction relation; z3 is asked for a model of its negation, and
`unsat` is the proof. docs/soundness.md ("Unbounded proof") gives the encoding, what it assumes
and the times measured. `WEAKENINGS` names preconditions and rules that can be left out or read
wrongly (`prove(..., weaken=...)`), so that a test sees a proof turn into a counterexample.
"""
from __future__ import annotations

import itertools
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable, Iterable

ASSERTIONS = ("SafeRemove", "SafeCreate", "SafeDetach", "SafeAttach", "SafeDegrade", "SafeUpgrade",
              "AbsentDegraded", "KeepsSingle", "KeepsOneServer")
# The invariants of all six actions together (whether or not Pre is valid), by the property kept.
INVARIANTS = ("AbsentDegraded", "KeepsSingle", "KeepsOneServer")
TIMEOUT_MS = 120_000   # per assertion; past it z3 answers unknown ("timeout"), never a proof

# Each precondition (named as the meta-model's `--@pre` labels) or rule can be left out; the
# last three are wrong readings of a precondition, each a way to get it unsafe.
WEAKENINGS: dict[str, str] = {
    "remove.present": "remove does not ask c to be present",
    "remove.isolated": "remove does not ask c's ports to be detached",
    "create.absent": "create does not ask c to be absent",
    "create.degraded": "create does not ask c's functionalities to be degraded",
    "detach.attached": "detach does not ask p to be attached to k",
    "detach.input": "detaching an input does not ask its component to be safe without the role",
    "detach.output": "detaching the last satisfying output does not ask k's readers to be safe without k",
    "attach.present": "attach does not ask p's component to be present",
    "attach.detached": "attach does not ask p to be detached from k",
    "attach.output": "attaching an output does not ask its guarantee to satisfy k's",
    "attach.input": "attaching an input does not ask k's guarantee to satisfy its assumption",
    "attach.single": "attaching an output does not ask a `single` topic to have no publisher",
    "attach.service": "attaching an output does not ask a service to have no server",
    "degrade.present": "degrade does not ask f to be present",
    "degrade.normal": "degrade does not ask f to be in its normal mode",
    "degrade.safe": "degrade does not ask the readers of the connectors it leaves unsatisfied to be safe",
    "upgrade.present": "upgrade does not ask f to be present",
    "upgrade.degraded": "upgrade does not ask f to be degraded",
    "upgrade.assumptions": "upgrade does not ask f's normal assumptions to hold",
    "modes.rule_iii": "rule (iii) on modes is not assumed (a degraded guarantee may satisfy more)",
    "detach.counts_itself": "detach's 'k satisfied by another attached output' counts p itself",
    "degrade.exempts_component": "degrade exempts every functionality of f's component, not only f",
    "degrade.counts_own_outputs": "degrade's 'k satisfied by another attached output' counts f's own outputs",
}


class Z3Unavailable(RuntimeError):
    pass


@dataclass
class Proof:
    assertion: str
    result: str                 # "proved" | "counterexample" | "unknown"
    seconds: float
    reason: str = ""            # z3's reason for unknown
    counterexample: dict[str, Any] | None = None


@dataclass
class UnboundedReport:
    proofs: list[Proof]
    z3_version: str
    weakened: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(p.result == "proved" for p in self.proofs)

    def to_json(self) -> dict[str, Any]:
        return {"unbounded": True, "z3": self.z3_version, "ok": self.ok, "weakened": self.weakened,
                "total_seconds": round(sum(p.seconds for p in self.proofs), 3),
                "assertions": [asdict(p) for p in self.proofs]}


def _z3() -> Any:
    try:
        import z3
    except ImportError as exc:
        raise Z3Unavailable(f"the z3 solver is not installed ({exc}): pip install z3-solver") from None
    return z3


Pred1 = Callable[[Any], Any]
Pred2 = Callable[[Any, Any], Any]


class _Vocabulary:
    """The sorts and the static relations (the same in Pre and Post), and fresh variables."""

    def __init__(self, z3: Any) -> None:
        self.z3 = z3
        sort = z3.DeclareSort
        self.Component, self.Input, self.Output = sort("Component"), sort("Input"), sort("Output")
        self.Functionality, self.Connector, self.Data = sort("Functionality"), sort("Connector"), sort("Data")
        fn, B = z3.Function, z3.BoolSort()
        F, I, O, D = self.Functionality, self.Input, self.Output, self.Data
        self.fowner = fn("fowner", F, self.Component)    # the component of a functionality
        self.iowner = fn("iowner", I, self.Component)    # ... of an input
        self.oowner = fn("oowner", O, self.Component)    # ... of an output
        self.assoc_in = fn("assoc_in", F, I, B)
        self.assoc_out = fn("assoc_out", F, O, B)
        self.nasms = fn("nasms", F, D, B)                # the normal mode's assumptions
        self.nguar = fn("nguar", F, O, D)                # the normal guarantee on an associated output
        self.dguar = fn("dguar", F, O, D)                # the degraded one
        self.iasm = fn("iasm", I, D)
        self.cguar = fn("cguar", self.Connector, D)
        self.envg = fn("envg", D, B)
        self.sat = fn("sat", D, D, B)                    # p satisfies q: any relation at all
        self.single = fn("single", self.Connector, B)    # the `single` topics
        self.service = fn("service", self.Connector, B)  # the services
        self._n = 0

    def var(self, sort: Any, name: str) -> Any:
        self._n += 1
        return self.z3.Const(f"{name}{self._n}", sort)

    def facts(self, weaken: frozenset[str]) -> list[Any]:
        z3 = self.z3
        f, i, o, d = (self.var(s, n) for s, n in ((self.Functionality, "f"), (self.Input, "i"),
                                                   (self.Output, "o"), (self.Data, "d")))
        out = [z3.ForAll([f, i], z3.Implies(self.assoc_in(f, i), self.iowner(i) == self.fowner(f))),
               z3.ForAll([f, o], z3.Implies(self.assoc_out(f, o), self.oowner(o) == self.fowner(f)))]
        if "modes.rule_iii" not in weaken:   # whatever a degraded guarantee satisfies, the normal one does
            out.append(z3.ForAll([f, o, d], z3.Implies(z3.And(self.assoc_out(f, o), self.sat(self.dguar(f, o), d)),
                                                       self.sat(self.nguar(f, o), d))))
        return out


NO_ROLE: Pred2 = lambda k, i: False   # noqa: E731


@dataclass
class _State:
    """A configuration: its relations as functions to z3 terms (Post is Pre with an update)."""
    v: _Vocabulary
    comps: Pred1
    degraded: Pred1
    rin: Pred2        # roles: connector -> input
    rout: Pred2       # roles: connector -> output

    def but(self, **changes: Any) -> "_State":
        fields = {"v": self.v, "comps": self.comps, "degraded": self.degraded, "rin": self.rin, "rout": self.rout}
        return _State(**{**fields, **changes})

    def present(self, f: Any) -> Any:
        return self.comps(self.v.fowner(f))

    def cur(self, f: Any, o: Any) -> Any:
        """f's guarantee on o in its current mode."""
        v = self.v
        return v.z3.If(self.degraded(f), v.dguar(f, o), v.nguar(f, o))

    def conn_sat(self, k: Any, but: Pred1 = lambda o: False) -> Any:
        """k is satisfied by an attached output (other than those `but` holds of) of a present functionality."""
        v, z3 = self.v, self.v.z3
        f, o = v.var(v.Functionality, "f"), v.var(v.Output, "o")
        return z3.Exists([f, o], z3.And(z3.Not(but(o)), self.present(f), v.assoc_out(f, o), self.rout(k, o),
                                        v.sat(self.cur(f, o), v.cguar(k))))

    def input_sat(self, i: Any, dead: Pred2) -> Any:
        """Input i is satisfied through a role other than the `dead` ones."""
        v, z3 = self.v, self.v.z3
        k = v.var(v.Connector, "k")
        return z3.Exists([k], z3.And(self.rin(k, i), z3.Not(dead(k, i)), self.conn_sat(k),
                                     v.sat(v.cguar(k), v.iasm(i))))

    def holds(self, f: Any, a: Any, dead: Pred2 = NO_ROLE) -> Any:
        v, z3 = self.v, self.v.z3
        i, g = v.var(v.Input, "i"), v.var(v.Data, "g")
        return z3.Or(z3.Exists([i], z3.And(v.assoc_in(f, i), v.sat(v.iasm(i), a), self.input_sat(i, dead))),
                     z3.Exists([g], z3.And(v.envg(g), v.sat(g, a))))

    def assumes(self, f: Any, a: Any) -> Any:
        """a is an assumption of f's current mode (the degraded mode assumes nothing)."""
        return self.v.z3.And(self.v.z3.Not(self.degraded(f)), self.v.nasms(f, a))

    def safe(self, who: Pred1 = lambda f: True, dead: Pred2 = NO_ROLE) -> Any:
        """Every assumption of the present functionalities `who` holds without the `dead` roles."""
        v, z3 = self.v, self.v.z3
        f, a = v.var(v.Functionality, "f"), v.var(v.Data, "a")
        return z3.ForAll([f, a], z3.Implies(z3.And(self.present(f), who(f), self.assumes(f, a)),
                                            self.holds(f, a, dead)))

    def valid(self) -> Any:
        return self.safe()

    def reads(self, c: Any, conns: Pred1) -> Any:
        """Component c has an input attached to one of `conns`."""
        v, z3 = self.v, self.v.z3
        k, i = v.var(v.Connector, "k"), v.var(v.Input, "i")
        return z3.Exists([k, i], z3.And(conns(k), self.rin(k, i), v.iowner(i) == c))

    def one_publisher(self, kind: Pred1) -> Any:
        """Every connector `kind` holds of has at most one attached output."""
        v, z3 = self.v, self.v.z3
        k, o1, o2 = v.var(v.Connector, "k"), v.var(v.Output, "o"), v.var(v.Output, "o")
        return z3.ForAll([k, o1, o2], z3.Implies(z3.And(kind(k), self.rout(k, o1), self.rout(k, o2)), o1 == o2))

    def absent_degraded(self) -> Any:
        v, z3 = self.v, self.v.z3
        f = v.var(v.Functionality, "f")
        return z3.ForAll([f], z3.Implies(z3.Not(self.present(f)), self.degraded(f)))


@dataclass
class _Action:
    name: str                       # e.g. "degrade"
    params: dict[str, Any]          # the action's arguments, as z3 constants
    pre: list[tuple[str, Any]]      # named preconditions
    post: _State

    def precondition(self, weaken: frozenset[str], z3: Any) -> Any:
        return z3.And([cond for label, cond in self.pre if label not in weaken])


@dataclass
class _Args:
    """The actions' arguments as z3 constants, shared by the six (as the meta-model's are)."""

    c: Any          # the component of remove and create
    k: Any          # the connector of detach and attach
    p_in: Any       # their port when it is an input,
    p_out: Any      # ... when it is an output,
    is_input: Any   # ... and which of the two it is
    f: Any          # the functionality of degrade and upgrade

    @property
    def port(self) -> dict[str, Any]:
        return {"k": self.k, "p_in": self.p_in, "p_out": self.p_out, "p_is_input": self.is_input}


def _remove(v: _Vocabulary, s: _State, x: _Args, weaken: frozenset[str]) -> _Action:
    z3, c = v.z3, x.c
    kk, ii, oo = v.var(v.Connector, "k"), v.var(v.Input, "i"), v.var(v.Output, "o")
    return _Action("remove", {"c": c}, [
        ("remove.present", s.comps(c)),
        ("remove.isolated", z3.And(z3.ForAll([kk, ii], z3.Implies(v.iowner(ii) == c, z3.Not(s.rin(kk, ii)))),
                                   z3.ForAll([kk, oo], z3.Implies(v.oowner(oo) == c, z3.Not(s.rout(kk, oo)))))),
    ], s.but(comps=lambda y: z3.And(s.comps(y), y != c),
             degraded=lambda g: z3.Or(s.degraded(g), v.fowner(g) == c)))


def _create(v: _Vocabulary, s: _State, x: _Args, weaken: frozenset[str]) -> _Action:
    z3, c = v.z3, x.c
    g = v.var(v.Functionality, "g")
    return _Action("create", {"c": c}, [
        ("create.absent", z3.Not(s.comps(c))),
        ("create.degraded", z3.ForAll([g], z3.Implies(v.fowner(g) == c, s.degraded(g)))),
    ], s.but(comps=lambda y: z3.Or(s.comps(y), y == c)))


def _detach(v: _Vocabulary, s: _State, x: _Args, weaken: frozenset[str]) -> _Action:
    z3, k, pi, po, is_in = v.z3, x.k, x.p_in, x.p_out, x.is_input
    And, Not, Implies = z3.And, z3.Not, z3.Implies
    others = (lambda o: False) if "detach.counts_itself" in weaken else (lambda o: o == po)
    return _Action("detach", x.port, [
        ("detach.attached", z3.If(is_in, s.rin(k, pi), s.rout(k, po))),
        ("detach.input", Implies(is_in, s.safe(lambda h: v.fowner(h) == v.iowner(pi),
                                               lambda k2, i2: And(k2 == k, i2 == pi)))),
        ("detach.output", Implies(And(Not(is_in), Not(s.conn_sat(k, others))),
                                  s.safe(lambda h: s.reads(v.fowner(h), lambda k2: k2 == k),
                                         lambda k2, i2: k2 == k))),
    ], s.but(rin=lambda k2, i2: And(s.rin(k2, i2), Not(And(is_in, k2 == k, i2 == pi))),
             rout=lambda k2, o2: And(s.rout(k2, o2), Not(And(Not(is_in), k2 == k, o2 == po)))))


def _attach(v: _Vocabulary, s: _State, x: _Args, weaken: frozenset[str]) -> _Action:
    z3, k, pi, po, is_in = v.z3, x.k, x.p_in, x.p_out, x.is_input
    And, Or, Not, If, Implies = z3.And, z3.Or, z3.Not, z3.If, z3.Implies
    h, o1, o2 = v.var(v.Functionality, "h"), v.var(v.Output, "o"), v.var(v.Output, "o")
    return _Action("attach", x.port, [
        ("attach.present", If(is_in, s.comps(v.iowner(pi)), s.comps(v.oowner(po)))),
        ("attach.detached", If(is_in, Not(s.rin(k, pi)), Not(s.rout(k, po)))),
        ("attach.output", Implies(Not(is_in), z3.Exists([h], And(s.present(h), v.assoc_out(h, po),
                                                                 v.sat(s.cur(h, po), v.cguar(k)))))),
        ("attach.input", Implies(is_in, v.sat(v.cguar(k), v.iasm(pi)))),
        ("attach.single", Implies(And(Not(is_in), v.single(k)), Not(z3.Exists([o1], s.rout(k, o1))))),
        ("attach.service", Implies(And(Not(is_in), v.service(k)), Not(z3.Exists([o2], s.rout(k, o2))))),
    ], s.but(rin=lambda k2, i2: Or(s.rin(k2, i2), And(is_in, k2 == k, i2 == pi)),
             rout=lambda k2, o2: Or(s.rout(k2, o2), And(Not(is_in), k2 == k, o2 == po))))


def _degrade(v: _Vocabulary, s: _State, x: _Args, weaken: frozenset[str]) -> _Action:
    z3, f0 = v.z3, x.f
    And, Not = z3.And, z3.Not
    # The connectors degrading f0 leaves unsatisfied: attached to an output of f0, satisfied by
    # no other attached output, nor by f0's degraded guarantee on an attached output of f0.
    own = (lambda o: False) if "degrade.counts_own_outputs" in weaken else (lambda o: v.assoc_out(f0, o))

    def aff(k2: Any) -> Any:
        o1, o2 = v.var(v.Output, "o"), v.var(v.Output, "o")
        return And(z3.Exists([o1], And(v.assoc_out(f0, o1), s.rout(k2, o1))),
                   Not(s.conn_sat(k2, own)),
                   Not(z3.Exists([o2], And(v.assoc_out(f0, o2), s.rout(k2, o2),
                                           v.sat(v.dguar(f0, o2), v.cguar(k2))))))
    exempt = ((lambda h2: v.fowner(h2) != v.fowner(f0)) if "degrade.exempts_component" in weaken
              else (lambda h2: h2 != f0))    # f0's degraded mode assumes nothing
    return _Action("degrade", {"f": f0}, [
        ("degrade.present", s.present(f0)),
        ("degrade.normal", Not(s.degraded(f0))),
        ("degrade.safe", s.safe(lambda h2: And(exempt(h2), s.reads(v.fowner(h2), aff)),
                                lambda k2, i2: aff(k2))),
    ], s.but(degraded=lambda h2: z3.Or(s.degraded(h2), h2 == f0)))


def _upgrade(v: _Vocabulary, s: _State, x: _Args, weaken: frozenset[str]) -> _Action:
    z3, f0 = v.z3, x.f
    a = v.var(v.Data, "a")
    return _Action("upgrade", {"f": f0}, [
        ("upgrade.present", s.present(f0)),
        ("upgrade.degraded", s.degraded(f0)),
        ("upgrade.assumptions", z3.ForAll([a], z3.Implies(v.nasms(f0, a), s.holds(f0, a)))),
    ], s.but(degraded=lambda h2: z3.And(s.degraded(h2), h2 != f0)))


# One entry per action: its preconditions and its Post (frame: all else unchanged), from s.
_ACTIONS: dict[str, Callable[[_Vocabulary, _State, _Args, frozenset[str]], _Action]] = {
    "remove": _remove, "create": _create, "detach": _detach, "attach": _attach,
    "degrade": _degrade, "upgrade": _upgrade,
}


def _actions(v: _Vocabulary, s: _State, weaken: frozenset[str]) -> dict[str, _Action]:
    """The six actions from s, each with its preconditions and its Post (frame: all else unchanged)."""
    z3 = v.z3
    args = _Args(z3.Const("c", v.Component), z3.Const("k", v.Connector), z3.Const("p_in", v.Input),
                 z3.Const("p_out", v.Output), z3.Bool("p_is_input"), z3.Const("f", v.Functionality))
    return {name: build(v, s, args, weaken) for name, build in _ACTIONS.items()}


def _setup(weaken: frozenset[str]) -> tuple[Any, _Vocabulary, _State, dict[str, _Action]]:
    z3 = _z3()
    v = _Vocabulary(z3)
    fn, B = z3.Function, z3.BoolSort()
    pre = _State(v, fn("comps", v.Component, B), fn("degraded", v.Functionality, B),
                 fn("roles_in", v.Connector, v.Input, B), fn("roles_out", v.Connector, v.Output, B))
    return z3, v, pre, _actions(v, pre, weaken)


def _solver(z3: Any, timeout_ms: int, rlimit: int) -> Any:
    solver = z3.Solver()
    solver.set("timeout", timeout_ms)
    if rlimit:
        solver.set("rlimit", rlimit)
    return solver


def prove(assertion: str, weaken: Iterable[str] = (), timeout_ms: int = TIMEOUT_MS, rlimit: int = 0) -> Proof:
    """Prove `assertion` (one of ASSERTIONS) for every size, with the `weaken`ings applied;
    `rlimit` bounds z3's work (0: only the timeout does)."""
    weakened = frozenset(weaken)
    unknown = weakened - set(WEAKENINGS)
    if assertion not in ASSERTIONS + RECOVERY_ASSERTIONS or unknown:
        raise ValueError(f"unknown assertion or weakening: {assertion}, {sorted(unknown)}")
    if assertion in RECOVERY_ASSERTIONS:
        return _prove_recovery(assertion, weakened, timeout_ms, rlimit)
    started = time.perf_counter()
    z3, v, pre, acts = _setup(weakened)
    act = None if assertion in INVARIANTS else acts[assertion[len("Safe"):].lower()]
    solver = _solver(z3, timeout_ms, rlimit)
    solver.add(v.facts(weakened))
    kept = _invariant(v, assertion)
    if act is None:   # an invariant of every action, whether or not Pre is valid
        solver.add(kept(pre), z3.Or([z3.And(a.precondition(weakened, z3), z3.Not(kept(a.post)))
                                     for a in acts.values()]))
    else:
        solver.add(pre.valid(), act.precondition(weakened, z3), z3.Not(act.post.valid()))
    answer = solver.check()
    seconds = round(time.perf_counter() - started, 3)
    if answer == z3.unsat:
        return Proof(assertion, "proved", seconds)
    if answer == z3.sat:
        cex = (_describe(solver.model(), v, pre, weakened, [act], lambda s: z3.Not(s.valid())) if act is not None
               else _describe(solver.model(), v, pre, weakened, list(acts.values()),
                              lambda s: z3.Not(kept(s))))
        return Proof(assertion, "counterexample", seconds, counterexample=cex)
    return Proof(assertion, "unknown", seconds, reason=solver.reason_unknown())


def _invariant(v: _Vocabulary, assertion: str) -> Callable[[_State], Any]:
    """What an invariant assertion keeps, of a configuration."""
    if assertion == "KeepsSingle":
        return lambda s: s.one_publisher(v.single)
    if assertion == "KeepsOneServer":
        return lambda s: s.one_publisher(v.service)
    return lambda s: s.absent_degraded()


def satisfiable(action: str, weaken: Iterable[str] = (), timeout_ms: int = TIMEOUT_MS) -> str:
    """"sat" when valid(Pre) and the action's preconditions can hold together, so that a proof
    of its Safe assertion is not vacuous (the meta-model's `run` for the action, unbounded)."""
    weakened = frozenset(weaken)
    z3, v, pre, acts = _setup(weakened)
    solver = _solver(z3, timeout_ms, 0)
    solver.add(v.facts(weakened) + [pre.valid(), acts[action].precondition(weakened, z3)])
    return str(solver.check())


def prove_all(weaken: Iterable[str] = (), timeout_ms: int = TIMEOUT_MS,
              after: Callable[[Proof], None] | None = None) -> UnboundedReport:
    proofs = []
    for name in ASSERTIONS + RECOVERY_ASSERTIONS:
        proofs.append(prove(name, weaken, timeout_ms))
        if after:
            after(proofs[-1])
    return UnboundedReport(proofs, _z3().get_version_string(), sorted(weaken))


# --- a counterexample, in the model's element names ------------------------------------

@dataclass
class _Reading:
    """A z3 model read in the meta-model's element names."""

    m: Any
    v: _Vocabulary

    def elems(self, sort: Any) -> list[Any]:
        return list(self.m.get_universe(sort) or [])

    def name(self, e: Any) -> str:
        text = str(e)
        return text.replace("!val!", "") if "!val!" in text else text

    def true(self, expr: Any) -> bool:
        """expr's value in m, quantifiers expanded over m's finite universes (m.eval leaves them)."""
        z3 = self.v.z3
        if z3.is_quantifier(expr):
            n = expr.num_vars()
            combos = itertools.product(*(self.elems(expr.var_sort(j)) for j in range(n)))
            # substitute_vars replaces the de Bruijn variable 0, the last bound, first
            cases = (self.true(z3.substitute_vars(expr.body(), *reversed(vals))) for vals in combos)
            return any(cases) if expr.is_exists() else all(cases)
        if z3.is_and(expr) or z3.is_or(expr):
            return (all if z3.is_and(expr) else any)(self.true(c) for c in expr.children())
        if z3.is_not(expr):
            return not self.true(expr.arg(0))
        if z3.is_implies(expr):
            return not self.true(expr.arg(0)) or self.true(expr.arg(1))
        return z3.is_true(self.m.eval(expr, model_completion=True))

    def ev(self, expr: Any) -> str:
        return self.name(self.m.eval(expr, model_completion=True))

    def of(self, owner: Any, x: Any) -> str:
        """`x` qualified by its component: Component1.Input0."""
        return f"{self.ev(owner(x))}.{self.name(x)}"

    def sorts(self) -> tuple[list[Any], ...]:
        """The elements of the components, inputs, outputs, functionalities, connectors, data."""
        v = self.v
        return tuple(self.elems(s) for s in (v.Component, v.Input, v.Output, v.Functionality, v.Connector, v.Data))

    def static(self) -> dict[str, Any]:
        """The static relations: what each element owns, assumes and guarantees."""
        v, name, ev, true = self.v, self.name, self.ev, self.true
        _, I, O, F, K, D = self.sorts()
        return {
            "functionalities": {name(f): {
                "component": ev(v.fowner(f)),
                "inputs": [name(i) for i in I if true(v.assoc_in(f, i))],
                "outputs": {name(o): {"normal": ev(v.nguar(f, o)), "degraded": ev(v.dguar(f, o))}
                            for o in O if true(v.assoc_out(f, o))},
                "assumes": [name(d) for d in D if true(v.nasms(f, d))]} for f in F},
            "inputs": {name(i): {"component": ev(v.iowner(i)), "assumes": ev(v.iasm(i))} for i in I},
            "outputs": {name(o): ev(v.oowner(o)) for o in O},
            "connectors": {name(k): ev(v.cguar(k)) for k in K},
            "environment": [name(d) for d in D if true(v.envg(d))],
            "satisfies": [f"{name(p)} sat {name(q)}" for p in D for q in D if true(v.sat(p, q))],
        }

    def config(self, s: _State) -> dict[str, Any]:
        """The configuration `s` in words."""
        v, name, of, true = self.v, self.name, self.of, self.true
        C, I, O, F, K, D = self.sorts()
        return {"components": [name(c) for c in C if true(s.comps(c))],
                "degraded": [of(v.fowner, f) for f in F if true(s.degraded(f))],
                "roles": [f"{name(k)} -> {of(v.iowner, i)}" for k in K for i in I if true(s.rin(k, i))]
                + [f"{name(k)} -> {of(v.oowner, o)}" for k in K for o in O if true(s.rout(k, o))],
                "unsatisfied": [f"{of(v.fowner, f)} assumes {name(d)}" for f in F for d in D
                                if true(v.z3.And(s.present(f), s.assumes(f, d))) and not true(s.holds(f, d))]}


def _describe(m: Any, v: _Vocabulary, pre: _State, weakened: frozenset[str], acts: list[_Action],
              bad: Callable[[_State], Any]) -> dict[str, Any]:
    """Model m as Pre, the action (the first of `acts` whose preconditions hold in m and whose
    Post is `bad`) and Post, the configurations in words, and the static relations."""
    r = _Reading(m, v)
    static = r.static()
    out: dict[str, Any] = {"pre": r.config(pre)}
    act = next((a for a in acts if r.true(a.precondition(weakened, v.z3)) and r.true(bad(a.post))), None)
    if act is not None:
        args = dict(act.params)
        if "p_is_input" in args:
            is_in = r.true(args.pop("p_is_input"))
            args.pop("p_out" if is_in else "p_in")
        out["action"] = act.name + " " + ", ".join(f"{k}={r.ev(x)}" for k, x in args.items())
        out["post"] = r.config(act.post)
    out["static"] = static
    return out


# --- the command -----------------------------------------------------------------------

def command(output_format: Any, weaken: Iterable[str] = ()) -> int:
    """`reconf verify-meta-model --unbounded`: prints the table (or JSON), returns the exit code."""
    import json

    import click
    from rich.console import Console
    from rich.table import Table

    console = Console(stderr=True)
    _z3()
    text = getattr(output_format, "value", output_format) == "text"
    progress = console.is_terminal and text

    def after(p: Proof) -> None:
        if progress:
            console.print(f"{'[green]✓' if p.result == 'proved' else '[red]✗'}[/] {p.assertion}: "
                          f"{p.result} in {p.seconds:.3f} s")

    report = prove_all(weaken, after=after)
    if not text:
        click.echo(json.dumps(report.to_json(), indent=2))
    else:
        table = Table(title=f"reconf meta-model, unbounded (z3 {report.z3_version})")
        for col in ("assertion", "result", "time"):
            table.add_column(col, justify="right" if col == "time" else "left")
        for p in report.proofs:
            shown = p.result + (f" ({p.reason})" if p.reason else "")
            table.add_row(p.assertion, shown, f"{p.seconds:.3f} s", style="" if p.result == "proved" else "bold red")
        console.print(table)
        for p in report.proofs:
            if p.counterexample:
                _render_counterexample(p.assertion, p.counterexample, console)
        verdict = "all proved for every size" if report.ok else "NOT ALL PROVED"
        console.print(f"{len(report.proofs)} assertions in {sum(p.seconds for p in report.proofs):.2f} s: {verdict}")
    return 0 if report.ok else 1


def _render_counterexample(assertion: str, cex: dict[str, Any], console: Any) -> None:
    """The two configurations and the action between them (the static part: --output-format json)."""
    console.print(f"[bold]{assertion}[/bold] counterexample" + (f": action {cex['action']}" if "action" in cex else ""))
    for name, key in (("before", "pre"), ("after", "post")):
        if key not in cex:
            continue
        conf = cex[key]
        console.print(f"  {name}:")
        for field_, shown in (("components", "components present"), ("degraded", "degraded"), ("roles", "roles"),
                              ("unsatisfied", "unsatisfied")):
            console.print(f"    {shown}: {', '.join(conf[field_]) or '(none)'}")


# --- restoring validity (docs/soundness.md#restoring-validity) ----------------------------
#
# A recovery starts from an observed configuration that need not be valid, and first degrades
# what fails (checker.planning.recovery). Two properties, over any configuration (valid or not):
#
# RecoverDegrade: degrading a present functionality f0 in its normal mode, one of whose
#   assumptions fails, makes no assumption fail that degrading its own functionality cannot
#   mend: whatever fails after is an assumption of a present functionality g other than f0 in
#   its normal mode (degrading g mends it: a degraded mode assumes nothing), and g either
#   failed before or reads a connector an output of f0 is attached to.
# RecoverMonotone: degrading more never mends anything else: with the same components and
#   attachments and a superset of degraded functionalities, an assumption of a functionality
#   still normal that fails with fewer degraded still fails. So the degrades the recovery makes
#   (the ones that fail, then the ones that fail once those are degraded, ...) are needed by
#   every valid configuration reached by degrading alone, and in any order each state fails
#   only on functionalities a later step degrades (a functionality failing midway fails at the
#   end unless degraded, and the end is valid).

RECOVERY_ASSERTIONS = ("RecoverDegrade", "RecoverMonotone")


def _recover_degrade(v: _Vocabulary, pre: _State) -> tuple[list[Any], _State]:
    """The negation of RecoverDegrade, and Post."""
    z3 = v.z3
    f0, a0 = z3.Const("f0", v.Functionality), z3.Const("a0", v.Data)
    g, a = z3.Const("g", v.Functionality), z3.Const("a", v.Data)
    post = pre.but(degraded=lambda h: z3.Or(pre.degraded(h), h == f0))

    def published(k: Any) -> Any:
        o = v.var(v.Output, "o")
        return z3.Exists([o], z3.And(v.assoc_out(f0, o), pre.rout(k, o)))
    claim = z3.And(g != f0, z3.Not(post.degraded(g)),
                   z3.Or(z3.And(pre.assumes(g, a), z3.Not(pre.holds(g, a))), pre.reads(v.fowner(g), published)))
    return [pre.present(f0), z3.Not(pre.degraded(f0)), v.nasms(f0, a0), z3.Not(pre.holds(f0, a0)),
            post.present(g), post.assumes(g, a), z3.Not(post.holds(g, a)), z3.Not(claim)], post


def _recover_monotone(v: _Vocabulary, pre: _State) -> tuple[list[Any], _State]:
    """The negation of RecoverMonotone, and the configuration with more degraded."""
    z3 = v.z3
    more = z3.Function("degraded_more", v.Functionality, z3.BoolSort())
    h = v.var(v.Functionality, "h")
    g, a = z3.Const("g", v.Functionality), z3.Const("a", v.Data)
    post = pre.but(degraded=more)
    return [z3.ForAll([h], z3.Implies(pre.degraded(h), more(h))),
            post.present(g), z3.Not(more(g)), v.nasms(g, a), z3.Not(pre.holds(g, a)), post.holds(g, a)], post


def _prove_recovery(assertion: str, weakened: frozenset[str], timeout_ms: int, rlimit: int) -> Proof:
    started = time.perf_counter()
    z3, v, pre, _ = _setup(weakened)
    negation, post = (_recover_degrade if assertion == "RecoverDegrade" else _recover_monotone)(v, pre)
    solver = _solver(z3, timeout_ms, rlimit)
    solver.add(v.facts(weakened) + negation)
    answer = solver.check()
    seconds = round(time.perf_counter() - started, 3)
    if answer == z3.unsat:
        return Proof(assertion, "proved", seconds)
    if answer == z3.sat:
        r = _Reading(solver.model(), v)
        return Proof(assertion, "counterexample", seconds,
                     counterexample={"pre": r.config(pre), "post": r.config(post), "static": r.static()})
    return Proof(assertion, "unknown", seconds, reason=solver.reason_unknown())


def recovery_breaks_a_reader(timeout_ms: int = TIMEOUT_MS) -> str:
    """"sat" when degrading a failing functionality can make another one fail that did not
    before (a reader of its output), so that RecoverDegrade's second case is not vacuous (the
    meta-model's `RecoverBreaksAReader`, unbounded)."""
    z3, v, pre, _ = _setup(frozenset())
    negation, post = _recover_degrade(v, pre)
    g, a = z3.Const("g", v.Functionality), z3.Const("a", v.Data)
    solver = _solver(z3, timeout_ms, 0)
    solver.add(v.facts(frozenset()) + negation[:-1] + [pre.holds(g, a)])
    return str(solver.check())
