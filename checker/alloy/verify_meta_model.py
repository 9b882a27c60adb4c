"""Run every command of the Alloy meta-model and compare each outcome with its `expect`:
the proof behind `reconf verify-meta-model` (the command is `checker.cli.verify_meta_model_cmd`)."""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

from checker.alloy import CommandOutcome, get_backend, metamodel_modules, parallel
from checker.alloy.bridge import DEFAULT_SOLVER
from checker.alloy.metamodel import MAIN

STATES = ("Pre", "Post")

# Paper 001 §4.3 checks each action `for 5`: at most five of each of its signatures. Its
# assertions relate two systems (`all s, s': System`); here they are Pre and Post, exactly.
PAPER_SCOPE = 5
PAPER_SIGS = ("Component", "Port", "Functionality", "Connector")


@dataclass
class CounterexampleState:
    """One configuration of a counterexample (its Pre or Post), in atom names; not the checker's
    `checker.semantic_model.config.Configuration`."""

    components: list[str]
    degraded: list[str]
    roles: dict[str, list[str]]
    unsatisfied: list[str] = field(default_factory=list)  # "Functionality$0 assumes Msg$1"


@dataclass
class Counterexample:
    action: str
    pre: CounterexampleState
    post: CounterexampleState


@dataclass
class CommandRow:
    command: str
    kind: str  # "check" | "run"
    scope: str
    outcome: str
    expected: str
    as_expected: bool | None
    seconds: float
    solver: str
    counterexample: Counterexample | None = None
    bounds: dict[str, str] = field(default_factory=dict)   # sig -> "<= 5" or "= 1", as solved


@dataclass
class VerifyReport:
    scope: int
    solver: str
    rows: list[CommandRow]
    wall: float = 0.0           # seconds, parsing and both processes' start included
    processes: int = 1

    @property
    def ok(self) -> bool:
        return all(r.as_expected is not False for r in self.rows)

    @property
    def total_seconds(self) -> float:
        return sum(r.seconds for r in self.rows)

    def below_paper(self) -> list[str]:
        """Each check's signature whose bound is below the paper's `for 5` (empty: every
        check covers at least the configurations the paper's do)."""
        return [f"{r.command}: {sig} {r.bounds.get(sig, 'unbounded')}" for r in self.rows if r.kind == "check"
                for sig in PAPER_SIGS if _most(r.bounds.get(sig)) < PAPER_SCOPE]

    def to_json(self) -> dict[str, Any]:
        return {"scope": self.scope, "solver": self.solver, "ok": self.ok,
                "total_seconds": round(self.total_seconds, 3), "wall_seconds": round(self.wall, 3),
                "processes": self.processes,
                "paper_scope": {"scope": PAPER_SCOPE, "signatures": list(PAPER_SIGS),
                                "below": self.below_paper()},
                "commands": [asdict(r) for r in self.rows]}


def _most(bound: str | None) -> int:
    return -1 if bound is None else int(bound.split()[-1])


def _names(tuples: set[tuple[str, ...]]) -> list[str]:
    return sorted(t[0] for t in tuples)


def _owners(o: CommandOutcome) -> dict[str, str]:
    """Port and functionality atoms, qualified by their component: `Component$1.Input$0`."""
    return {x: f"{c}.{x}" for c, x in o.eval("inputs + outputs + funcs")}


def _counterexample_state(o: CommandOutcome, state: str, owner: dict[str, str]) -> CounterexampleState:
    roles: dict[str, list[str]] = {}
    for k, p in sorted(o.eval(f"{state}.roles")):
        roles.setdefault(k, []).append(owner.get(p, p))
    unsat = o.eval(f"{{ f: present_funcs[{state}], a: cur_asms[{state}, f] | not asm_holds[{state}, f, a] }}")
    return CounterexampleState(
        components=_names(o.eval(f"{state}.comps")),
        degraded=[owner.get(f, f) for f in _names(o.eval(f"{state}.degraded"))],
        roles=roles,
        unsatisfied=[f"{owner.get(f, f)} assumes {a}" for f, a in sorted(unsat)],
    )


def _action(pre: CounterexampleState, post: CounterexampleState) -> str:
    steps = [f"remove {c}" for c in sorted(set(pre.components) - set(post.components))]
    steps += [f"create {c}" for c in sorted(set(post.components) - set(pre.components))]
    pre_roles = {(k, p) for k, ps in pre.roles.items() for p in ps}
    post_roles = {(k, p) for k, ps in post.roles.items() for p in ps}
    steps += [f"detach {p} from {k}" for k, p in sorted(pre_roles - post_roles)]
    steps += [f"attach {p} to {k}" for k, p in sorted(post_roles - pre_roles)]
    # the modes of a removed or created component's functionalities belong to that action
    moved = set(pre.components) ^ set(post.components)
    own = [f for f in set(pre.degraded) ^ set(post.degraded) if f.split(".")[0] not in moved]
    steps += [f"degrade {f}" for f in sorted(own) if f in post.degraded]
    steps += [f"upgrade {f}" for f in sorted(own) if f in pre.degraded]
    return "; ".join(steps) or "(no change)"


def counterexample(o: CommandOutcome) -> Counterexample:
    owner = _owners(o)
    pre, post = (_counterexample_state(o, s, owner) for s in STATES)
    return Counterexample(_action(pre, post), pre, post)


def _row(o: CommandOutcome, bounds: dict[str, tuple[int, bool]]) -> CommandRow:
    expected = "-" if o.expects is None or o.expects < 0 else (
        ("counterexample" if o.expects else "no counterexample") if o.is_check
        else ("instance" if o.expects else "no instance"))
    cex = counterexample(o) if o.is_check and o.satisfiable else None
    return CommandRow(o.label, "check" if o.is_check else "run", o.scope, o.outcome, expected,
                      o.as_expected, round(o.elapsed, 3), o.solver, cex,
                      {sig: f"{'=' if exact else '<='} {n}" for sig, (n, exact) in sorted(bounds.items())})


def verify_meta_model(scope: int = 5, solver: str = DEFAULT_SOLVER,
                 before: Callable[[str, int, int], None] | None = None,
                 after: Callable[[CommandRow], None] | None = None,
                 modules: dict[str, str] | None = None) -> VerifyReport:
    """Run every command of the meta-model (checks at `scope`), in two processes where there
    are two cores (`checker.alloy.parallel`); raises AlloyUnavailable."""

    started = time.perf_counter()
    bridge = get_backend()
    modules = modules or metamodel_modules(scope)
    labels = bridge.commands(modules, MAIN)
    used = bridge.usable_solver(solver)
    bounds = bridge.bounds(modules, MAIN)
    processes = 1
    # the helper is started (or found) first, so the progress line says what happens
    if len(modules) == 1 and parallel.helper_for(len(labels), used, minimum=2) is not None:
        if before:
            before(f"all {len(labels)} commands, in 2 processes", 0, len(labels))
        work = [parallel.Job(MAIN, modules[MAIN], label, constants=False) for label in labels]
        verdicts, processes, _ = parallel.judge_many(work, used, minimum=2)
        outcomes = bridge.outcomes_of(modules, MAIN, {lab: (v.satisfiable, v.solve)
                                                      for lab, v in zip(labels, verdicts)}, used)
    else:
        outcomes = []
        for n, label in enumerate(labels, 1):
            if before:
                before(label, n, len(labels))
            outcomes += bridge.run(modules, MAIN, label, used)
    rows = []
    for o in outcomes:
        if o.is_check and o.satisfiable and o._evaluator is None:   # judged elsewhere: solved again here
            (o,) = bridge.run(modules, MAIN, o.label, used)
        row = _row(o, bounds[o.label])
        rows.append(row)
        if after:
            after(row)
    return VerifyReport(scope, used, rows, time.perf_counter() - started, processes)
