"""Completeness of planning: is every generated problem decided, and how far is `default` from the optimum?

    python -m bench.bench_completeness [--quick] [--shapes chain,tree,dag,fanin,cycle]
                                       [--sizes 10,20,30,50] [--seeds 3] [--box 2] [--jobs 1]
                                       [--list]

Problems: every shape of `bench.gen` at every size and seed, and on each four operations:
replace and remove of the hub (`bench.gen.hub_component`, as bench_plan replaces it) and of a
leaf (the last component whose outputs nobody reads; in the cycle shape, where every
component is read, the last one). The new versions are declared as `--version` declares the
hub's (`<name>_v2 replaces <name>`, the same ports and modes).

Default run: 5 shapes x 4 sizes x 3 seeds x 4 operations = 240 problems, about 5 minutes
on one core; `--quick`: sizes 10 and 20, one seed (40 problems, under a minute).

Per problem, in this process:
  alone    each strategy by itself (`checker.planning.solve`): default, paper, and exhaustive
           with a budget of --box seconds; the exhaustive plan is the optimum when its A*
           completed within the budget (`Search.optimal`), else the optimum is unknown
  command  the path `reconf plan` takes (`checker.planning.chain`: default → paper →
           exhaustive, the same budget; the Alloy planner is left out, as with --no-alloy)

Table, per size (and in all):
  problems   operations planned
  decided    the command found a plan, or proved that none exists (and how many proofs)
  optimum    problems whose optimum is known (exhaustive's A* completed within the box)
  default=   of those, the share where `default` found a plan of that disruption
  max gap    the largest disruption of `default` over the optimum
  lost       problems where some strategy alone found a plan and the command reported none
             (must be 0)
  d<p        problems where `paper` found a plan and `default` none (must be 0)
  cmd s      the command's slowest time on one problem

Exit status 1 when a problem is lost, default fails where paper succeeds, or a problem of at
most 20 components is not decided.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass
from typing import Iterator, Optional

from checker.planning import Fallback, NoPlanFound, NoSafePlan, plan_with_fallback, solve
from checker.planning.exhaustive import Budget, exhaustive_search
from checker.planning.operations import remove_problem, replace_problem
from checker.planning.plan import Problem, ready, verify
from reconf_dsl.loader import load_text

from .gen import SHAPES, Model, build, hub_component, render

OPERATIONS = ("replace hub", "remove hub", "replace leaf", "remove leaf")


def leaf(model: Model) -> str:
    """The last component whose outputs nobody reads (the last component if every one is read)."""
    read = {t for c in model.comps for _, t in c.inputs}
    quiet = [c.name for c in model.comps if not any(t in read for _, t in c.outputs)]
    return quiet[-1] if quiet else model.comps[-1].name


def problems(shapes: list[str], sizes: list[int], seeds: int) -> Iterator[tuple[str, Problem]]:
    """(name, problem) for every shape, size, seed and operation."""
    for n in sizes:
        for shape in shapes:
            for seed in range(seeds):
                model = build(shape, n, seed)
                for op in OPERATIONS:
                    verb, which = op.split()
                    who = hub_component(shape, n) if which == "hub" else leaf(model)
                    system = load_text(render(model, version_of=who), f"{shape}_{n}_{seed}.arch")
                    name = f"{shape} {n} seed {seed}: {verb} {which} {who}"
                    yield name, (replace_problem(system, who, f"{who}_v2") if verb == "replace"
                                 else remove_problem(system, who))


@dataclass
class Outcome:
    name: str
    size: int
    default: Optional[int]          # disruption, None when no plan
    paper: Optional[int]
    exhaustive: Optional[int]
    optimum: Optional[int]          # when exhaustive's A* completed
    decided: bool                   # the command found a plan or proved there is none
    proof: str                      # how "no plan" was proved ("" when a plan was found or nothing decided)
    command: Optional[int]          # the command's plan's disruption
    command_strategy: str
    seconds: float                  # the command's time


def _alone(problem: Problem, strategy: str) -> Optional[int]:
    try:
        return solve(problem, strategy).disruption
    except NoSafePlan:
        return None


def run_one(name: str, problem: Problem, box: float) -> Outcome:
    size = len(problem.system.components)
    default, paper = _alone(problem, "default"), _alone(problem, "paper")
    exhaustive = optimum = None
    try:
        settled = ready(problem)
        search = exhaustive_search(settled.system, settled.start, settled.goal, Budget(seconds=box))
        exhaustive = verify(settled.system, settled.start, search.steps, settled.goal, "exhaustive").disruption
        optimum = exhaustive if search.optimal else None
    except NoSafePlan:
        pass
    t0 = time.perf_counter()
    proof, command, strategy, decided = "", None, "", True
    try:
        p = plan_with_fallback(problem, "default", Fallback(budget=Budget(seconds=box)))
        command, strategy = p.disruption, p.strategy
    except NoPlanFound as e:
        last = e.attempts[-1] if e.attempts else None
        decided = last is not None and last.outcome == "none exists"
        proof = last.how if last is not None and decided else ""
    except NoSafePlan:
        proof = "target refused"      # the start is not valid or the target cannot be made valid
    return Outcome(name, size, default, paper, exhaustive, optimum, decided, proof, command, strategy,
                   time.perf_counter() - t0)


def _run(args: tuple[str, Problem, float]) -> Outcome:
    return run_one(*args)


def table(outcomes: list[Outcome], box: float) -> list[str]:
    header = (f"{'N':>5} {'problems':>8} {'decided':>8} {'(no plan)':>9} {'optimum':>8} {'default=':>9} "
              f"{'max gap':>8} {'lost':>5} {'d<p':>4} {'cmd s':>6}")
    lines = [f"Completeness: the command's path (default → paper → exhaustive, no Alloy), "
             f"time-boxed at {box:g} s a problem for the exhaustive search",
             header, "-" * len(header)]
    groups = sorted({o.size for o in outcomes})
    for label, rows in [(str(n), [o for o in outcomes if o.size == n]) for n in groups] + [("all", outcomes)]:
        if label == "all":
            lines.append("-" * len(header))
        decided = [o for o in rows if o.decided]
        none = [o for o in decided if o.command is None]
        known = [o for o in rows if o.optimum is not None]
        equal = [o for o in known if o.default == o.optimum]
        gaps = [o.default - o.optimum for o in known if o.default is not None and o.optimum is not None]
        lost = [o for o in rows if o.command is None and any(x is not None for x in (o.default, o.paper,
                                                                                     o.exhaustive))]
        worse = [o for o in rows if o.paper is not None and o.default is None]
        lines.append(f"{label:>5} {len(rows):>8} {_pct(len(decided), len(rows)):>8} {len(none):>9} "
                     f"{len(known):>8} {_pct(len(equal), len(known)):>9} {max(gaps, default=0):>8} "
                     f"{len(lost):>5} {len(worse):>4} {max((o.seconds for o in rows), default=0):>6.1f}")
    return lines


def _pct(k: int, n: int) -> str:
    return f"{100 * k / n:.0f}%" if n else "-"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_completeness", description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument("--sizes", default="10,20,30,50", help="comma-separated component counts")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per shape and size")
    ap.add_argument("--box", type=float, default=2.0, help="seconds the exhaustive search may take per problem")
    ap.add_argument("--jobs", type=int, default=1, help="problems planned at once, in worker processes")
    ap.add_argument("--quick", action="store_true", help="sizes 10 and 20, one seed")
    ap.add_argument("--list", action="store_true", help="print every problem's outcome too")
    args = ap.parse_args(argv)
    if args.quick:
        args.sizes, args.seeds = "10,20", 1
    shapes = [s.strip() for s in args.shapes.split(",") if s.strip()]
    for s in shapes:
        if s not in SHAPES:
            ap.error(f"unknown shape {s!r}; one of {', '.join(SHAPES)}")
    sizes = sorted(int(x) for x in args.sizes.split(","))
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cpus, {args.jobs} job(s)")
    work = [(name, p, args.box) for name, p in problems(shapes, sizes, args.seeds)]
    t0 = time.perf_counter()
    if args.jobs > 1:
        import multiprocessing as mp
        with mp.get_context("spawn").Pool(args.jobs) as pool:
            outcomes = pool.map(_run, work, chunksize=1)
    else:
        outcomes = [_run(w) for w in work]
    if args.list:
        for o in outcomes:
            said = (f"plan {o.command} ({o.command_strategy})" if o.command is not None else
                    f"no plan ({o.proof})" if o.decided else "UNDECIDED")
            print(f"{o.name:<40} default {_dis(o.default):>5} paper {_dis(o.paper):>5} "
                  f"optimum {_dis(o.optimum):>5}  command: {said}, {o.seconds:.1f} s")
    print("\n".join(table(outcomes, args.box)))
    proofs = {how: sum(1 for o in outcomes if o.proof == how) for how in sorted({o.proof for o in outcomes} - {""})}
    print(f"{len(outcomes)} problems in {time.perf_counter() - t0:.0f} s; no plan proved by "
          + (", ".join(f"{how} {n}" for how, n in proofs.items()) or "nothing (every problem has a plan)"))
    bad = [o.name for o in outcomes if o.command is None and any(x is not None for x in (o.default, o.paper,
                                                                                         o.exhaustive))]
    bad += [o.name for o in outcomes if o.paper is not None and o.default is None]
    bad += [o.name for o in outcomes if not o.decided and o.size <= 20]
    for name in bad:
        print(f"FAIL: {name}")
    return 1 if bad else 0


def _dis(x: Optional[int]) -> str:
    return "-" if x is None else str(x)


if __name__ == "__main__":
    sys.exit(main())
