"""`reconf verify-meta-model --unbounded`: the six Safe assertions and AbsentDegraded proved with z3
for every size; planted bugs in the preconditions and rules come back as counterexamples, a
solver that gives up says unknown, the command's exit codes follow, and the encoding reads
validity and the preconditions of example architectures as the Python engine does."""
from __future__ import annotations

import json
from typing import Any

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.semantic_model import unbounded
from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Upgrade,
    catalogue,
    effect,
    is_valid,
    preconditions,
)
from checker.semantic_model.config import Configuration
from checker.semantic_model.unbounded import ASSERTIONS, RECOVERY_ASSERTIONS, WEAKENINGS, prove, satisfiable
from reconf_dsl.ir import NOTHING, Predicate, System, satisfies
from reconf_dsl.loader import load
from tests.examples_table import BY_NAME


def test_every_assertion_is_proved() -> None:
    report = unbounded.prove_all()
    every = ASSERTIONS + RECOVERY_ASSERTIONS
    assert [p.assertion for p in report.proofs] == list(every)
    assert [(p.assertion, p.result) for p in report.proofs] == [(a, "proved") for a in every]
    assert report.ok


@pytest.mark.parametrize("action", ["remove", "create", "detach", "attach", "degrade", "upgrade"])
def test_the_preconditions_can_hold_in_a_valid_configuration(action: str) -> None:
    """Otherwise the action's proof would be vacuous."""
    assert satisfiable(action) == "sat"


# Each planted bug, the assertion that must catch it, and the action of its counterexample.
BUGS = [
    ("remove.isolated", "SafeRemove", "remove"),
    ("create.degraded", "SafeCreate", "create"),
    ("detach.input", "SafeDetach", "detach"),
    ("detach.output", "SafeDetach", "detach"),
    ("detach.counts_itself", "SafeDetach", "detach"),
    ("degrade.safe", "SafeDegrade", "degrade"),
    ("degrade.exempts_component", "SafeDegrade", "degrade"),
    ("degrade.counts_own_outputs", "SafeDegrade", "degrade"),
    ("upgrade.assumptions", "SafeUpgrade", "upgrade"),
    ("modes.rule_iii", "SafeUpgrade", "upgrade"),
    ("upgrade.present", "AbsentDegraded", "upgrade"),
    ("attach.single", "KeepsSingle", "attach"),
    ("attach.service", "KeepsOneServer", "attach"),
]


@pytest.mark.parametrize("weakening, assertion, action", BUGS, ids=[b[0] for b in BUGS])
def test_a_planted_bug_is_a_counterexample(weakening: str, assertion: str, action: str) -> None:
    proof = prove(assertion, [weakening])
    assert proof.result == "counterexample", proof
    cex = proof.counterexample
    assert cex is not None and cex["action"].startswith(action + " ")
    if assertion.startswith("Safe"):    # read again over the model's finite universes
        assert cex["pre"]["unsatisfied"] == [] and cex["post"]["unsatisfied"], cex
    elif assertion.startswith("Keeps"):  # a second publisher attached
        assert cex["action"].startswith("attach ") and cex["pre"]["roles"] != cex["post"]["roles"], cex
    else:                               # a functionality of an absent component is normal after
        owner = {f: d["component"] for f, d in cex["static"]["functionalities"].items()}
        post = cex["post"]
        assert any(c not in post["components"] and f"{c}.{f}" not in post["degraded"] for f, c in owner.items()), cex


def test_every_planted_bug_names_a_weakening() -> None:
    assert {w for w, _, _ in BUGS} <= set(WEAKENINGS)
    with pytest.raises(ValueError):
        prove("SafeDegrade", ["degrade.no_such_thing"])


def test_attach_is_safe_whatever_it_requires() -> None:
    """Attaching only adds satisfaction: its preconditions serve well-typed connections."""
    assert prove("SafeAttach", [w for w in WEAKENINGS if w.startswith("attach.")]).result == "proved"


@pytest.mark.parametrize("assertion, kind", [("KeepsSingle", "single"), ("KeepsOneServer", "service")])
def test_a_single_topic_and_a_service_are_reached(assertion: str, kind: str) -> None:
    """The one-publisher proofs are not vacuous: a valid configuration can attach the first
    publisher of a `single` topic or the first server of a service."""
    import z3

    from checker.semantic_model import unbounded as u
    _, v, pre, acts = u._setup(frozenset())
    solver = z3.Solver()
    solver.add(v.facts(frozenset()) + [pre.valid(), acts["attach"].precondition(frozenset(), z3),
                                       z3.Not(z3.Bool("p_is_input")), getattr(v, kind)(z3.Const("k", v.Connector))])
    assert solver.check() == z3.sat


def test_a_solver_that_gives_up_is_unknown_not_proved() -> None:
    proof = prove("SafeDegrade", rlimit=1)
    assert proof.result == "unknown" and proof.reason, proof


def _json(argv: list[str]) -> tuple[int, dict]:  # type: ignore[type-arg]
    r = CliRunner().invoke(main, argv)
    return r.exit_code, (json.loads(r.stdout) if r.stdout.strip() else {"stderr": r.stderr})


def test_the_command_proves_all_and_exits_0() -> None:
    code, doc = _json(["verify-meta-model", "--unbounded", "--output-format", "json"])
    assert code == 0, doc
    assert doc["ok"] and [a["result"] for a in doc["assertions"]] == ["proved"] * len(ASSERTIONS + RECOVERY_ASSERTIONS)


def test_the_command_exits_1_on_a_counterexample_or_unknown(monkeypatch: pytest.MonkeyPatch) -> None:
    planted = unbounded.prove_all
    monkeypatch.setattr(unbounded, "prove_all", lambda weaken=(), **kw: planted(["degrade.safe"], **kw))
    code, doc = _json(["verify-meta-model", "--unbounded", "--output-format", "json"])
    assert code == 1 and not doc["ok"]
    assert {a["assertion"]: a["result"] for a in doc["assertions"]}["SafeDegrade"] == "counterexample"
    r = CliRunner().invoke(main, ["verify-meta-model", "--unbounded"])
    assert r.exit_code == 1 and "SafeDegrade counterexample: action degrade" in r.stderr, r.stderr
    monkeypatch.setattr(unbounded, "prove_all", lambda *a, **k: unbounded.UnboundedReport(
        [prove("SafeDegrade", rlimit=1)], "test"))
    code, doc = _json(["verify-meta-model", "--unbounded", "--output-format", "json"])
    assert code == 1 and doc["assertions"][0]["result"] == "unknown"


def test_the_command_without_z3_exits_2(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing() -> None:
        raise unbounded.Z3Unavailable("the z3 solver is not installed: pip install z3-solver")
    monkeypatch.setattr(unbounded, "_z3", missing)
    r = CliRunner().invoke(main, ["verify-meta-model", "--unbounded"])
    assert r.exit_code == 2 and "RC011" in r.stdout + r.stderr and "Traceback" not in r.stdout + r.stderr


# --- the encoding is the engine's semantics ---------------------------------------------
# An architecture and a configuration become a finite structure for the encoding's symbols
# (closed, distinct domains; every relation and function fixed); z3's reading of validity and
# of each action's preconditions there is held to the verdicts of checker.semantic_model.actions.

class _Structure:
    def __init__(self, system: System, config: Configuration) -> None:
        z3, v, pre, self.acts = unbounded._setup(frozenset())
        self.z3, self.pre = z3, pre
        cat = catalogue(system)
        self.atoms: dict[str, dict[Any, Any]] = {}
        funcs, ports = cat.funcs, cat.ports
        F = {fid: self.atom(v.Functionality, fid) for fid in funcs}
        I = {pid: self.atom(v.Input, pid) for pid, p in ports.items() if p.kind == "input"}
        O = {pid: self.atom(v.Output, pid) for pid, p in ports.items() if p.kind == "output"}
        C = {c: self.atom(v.Component, c) for c in cat.comps}
        K = {k: self.atom(v.Connector, k) for k in cat.conns}
        modes = [m for f in funcs.values() for m in (f.normal, f.degraded) if m is not None]
        datum = {self._key(p): p for p in [NOTHING] + list(cat.env) + [k.guarantee for k in cat.conns.values()]
                 + [p.assumption for p in ports.values() if p.assumption is not None]
                 + [a for m in modes for a in m.assumptions] + [g.predicate for m in modes for g in m.guarantees]}
        D = {key: self.atom(v.Data, key) for key in datum}
        for sort in (v.Component, v.Input, v.Output, v.Functionality, v.Connector, v.Data):
            if not self.atoms.get(str(sort)):
                self.atom(sort, "unused")      # a sort is never empty
        d = lambda p: D[self._key(p)]  # noqa: E731
        self.facts: list[Any] = []
        fx = self.facts
        for (c, fname), f in funcs.items():
            fx.append(v.fowner(F[(c, fname)]) == C[c])
            for pid, o in O.items():
                if pid[0] == c and pid[1] in f.ports:
                    fx += [v.nguar(F[(c, fname)], o) == d(f.normal.guarantee(pid[1])),
                           v.dguar(F[(c, fname)], o) == d(f.degraded.guarantee(pid[1]))]
        fx += [v.iowner(i) == C[pid[0]] for pid, i in I.items()] + [v.oowner(o) == C[pid[0]] for pid, o in O.items()]
        fx += [v.iasm(i) == d(ports[pid].assumption) for pid, i in I.items()]
        fx += [v.cguar(K[k]) == d(conn.guarantee) for k, conn in cat.conns.items()]
        self.relation(v.assoc_in, [(F[fid], i) for fid, f in funcs.items() for pid, i in I.items()
                                   if pid[0] == fid[0] and pid[1] in f.ports])
        self.relation(v.assoc_out, [(F[fid], o) for fid, f in funcs.items() for pid, o in O.items()
                                    if pid[0] == fid[0] and pid[1] in f.ports])
        self.relation(v.nasms, [(F[fid], d(a)) for fid, f in funcs.items() for a in f.normal.assumptions])
        self.relation(v.envg, [(d(e),) for e in cat.env])
        self.relation(v.single, [(K[k],) for k, conn in cat.conns.items() if conn.single and conn.kind != "service"])
        self.relation(v.service, [(K[k],) for k, conn in cat.conns.items() if conn.kind == "service"])
        self.relation(v.sat, [(D[p], D[q]) for p in datum for q in datum if satisfies(datum[p], datum[q])])
        self.relation(pre.comps, [(C[c],) for c in config.components if c in C])
        self.relation(pre.degraded, [(F[fid],) for fid in funcs
                                     if fid in config.degraded or fid[0] not in config.components])
        self.relation(pre.rin, [(K[k], I[(c, p)]) for k, c, p in config.roles if (c, p) in I and k in K])
        self.relation(pre.rout, [(K[k], O[(c, p)]) for k, c, p in config.roles if (c, p) in O and k in K])
        for sort_name, atoms in self.atoms.items():
            mine = list(atoms.values())
            x = z3.Const("x", mine[0].sort())
            fx += [z3.Distinct(*mine) if len(mine) > 1 else z3.BoolVal(True),
                   z3.ForAll([x], z3.Or([x == a for a in mine]))]
        self.F, self.I, self.O, self.C, self.K = F, I, O, C, K
        self.solver = z3.Solver()
        self.solver.add(fx)
        assert self.solver.check() == z3.sat

    @staticmethod
    def _key(p: Predicate) -> tuple[Any, ...]:
        return (p.message, p.hz)

    def atom(self, sort: Any, key: Any) -> Any:
        return self.atoms.setdefault(str(sort), {}).setdefault(key, self.z3.Const(f"{sort}:{key}", sort))

    def relation(self, fn: Any, rows: list[tuple[Any, ...]]) -> None:
        xs = [self.z3.Const(f"x{n}", fn.domain(n)) for n in range(fn.arity())]
        rows_ = [self.z3.And([x == a for x, a in zip(xs, row)]) for row in rows]
        self.facts.append(self.z3.ForAll(xs, fn(*xs) == self.z3.Or(rows_)))

    def holds(self, formula: Any, *fixed: Any) -> bool:
        """formula's truth in the structure (with the action's arguments `fixed`), which decides it."""
        z3, s = self.z3, self.solver
        answers = []
        for f in (formula, z3.Not(formula)):
            s.push()
            s.add(*fixed, f)
            answers.append(s.check())
            s.pop()
        assert sorted(map(str, answers)) == ["sat", "unsat"], answers
        return answers[0] == z3.sat

    def arguments(self, a: Action) -> list[Any]:
        """The action's arguments, as equalities on the encoding's constants."""
        params = self.acts[a.kind].params
        if isinstance(a, (Remove, Create)):
            return [params["c"] == self.C[a.component]]
        if isinstance(a, (Degrade, Upgrade)):
            return [params["f"] == self.F[(a.component, a.functionality)]]
        is_in = (a.component, a.port) in self.I
        port = self.I[(a.component, a.port)] if is_in else self.O[(a.component, a.port)]
        return [params["k"] == self.K[a.connector], params["p_is_input"] == self.z3.BoolVal(is_in),
                params["p_in" if is_in else "p_out"] == port]


def _candidates(system: System, config: Configuration) -> list[Action]:
    cat = catalogue(system)
    out: list[Action] = [k(c) for c in cat.comps for k in (Remove, Create)]  # type: ignore[abstract]
    out += [k(conn, c, p) for conn in cat.conns for (c, p) in cat.ports for k in (Detach, Attach)]
    out += [k(c, f) for (c, f) in cat.funcs for k in (Degrade, Upgrade)]
    return out


# What checker.semantic_model.actions asks beyond the encoding's preconditions (each makes it safer still):
# a present component for a detached port, and for an upgrade that rule (iii) holds, which the
# DSL already checks. Neither weakens what is proved.
EXTRAS = ("is not in the system", "rule iii")


@pytest.mark.parametrize("name", ["chatter", "chatter_slow", "robot", "redundant", "cycle"])
def test_the_encoding_reads_configurations_as_the_engine_does(name: str) -> None:
    system = load([BY_NAME[name].file])
    config = Configuration.initial(system)
    verdicts: dict[tuple[bool, bool], int] = {}
    # the deployed configuration, and the one the first safe action leads to from it
    for here in [config] + [effect(system, config, a) for a in _candidates(system, config)
                            if not preconditions(system, config, a)][:1]:
        st = _Structure(system, here)
        assert st.holds(st.pre.valid()) == is_valid(system, here), here
        for a in _candidates(system, here):
            refused = preconditions(system, here, a)
            ok = st.holds(st.acts[a.kind].precondition(frozenset(), st.z3), *st.arguments(a))
            if refused and ok:
                assert all(any(x in r for x in EXTRAS) for r in refused), (a, refused)
            else:
                assert ok == (not refused), (a, refused)
            # Post, as the encoding updates Pre, is valid exactly when the engine's effect is
            # (but for creating a present component, which the engine's effect degrades)
            valid = is_valid(system, effect(system, here, a))
            if not (isinstance(a, Create) and a.component in here.components):
                assert st.holds(st.acts[a.kind].post.valid(), *st.arguments(a)) == valid, a
            verdicts[(ok, valid)] = verdicts.get((ok, valid), 0) + 1
    assert verdicts.get((True, True)) and verdicts.get((False, False)), verdicts   # both kinds were judged
