"""Planner benchmarks: plan time on big systems, and plan quality against `paper` and the optimum.

    python -m bench.bench_plan [--shapes fanin,dag] [--sizes 100,1000,10000] [--seed 0]
                               [--quality 200] [--optimum 60] [--skip-time] [--profile SHAPE:N]

Three tables:

1. time: `replace` of the hub component (`bench.gen.hub_component`) by the version that
   `generate(..., version=True)` declares, default strategy, in this process:
     parse   `reconf_dsl.loader.load([path])`
     plan    `checker.planning.plan_replace` (planning, choosing, verifying)
     verify  how the returned plan was checked (`full`: every state by `semantics.evaluate`;
             `local`: see `checker.planning.plan.verify`)
     full s  a full re-evaluation of every state of that plan (`verify(..., full=True)`),
             measured up to 2,000,000 states x components, estimated (~) beyond from one state
   Target: 1,000 components planned in under 2 s.
2. default vs paper: disruption of both strategies on generated systems of 4 to 40
   components, every shape, several seeds, `replace` of the hub. Default must never be worse:
   the script exits 1 if it is.
3. default vs the exhaustive optimum on systems of at most 8 components.
4. the command as a user runs it: `reconf plan replace HUB -f FILE --no-alloy` in a fresh
   process, text output and `--output-format json`: wall time, peak memory (the process's
   maximum resident set, from `os.wait4`) and the JSON document's size.
   Target: 10,000 components planned in under 60 s and 1 GB.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Iterator, Optional

from checker.planning import NoSafePlan, Plan, plan_replace
from checker.planning.exhaustive import SearchTooLarge
from checker.planning.plan import verify
from checker.semantic_model.semantics import evaluate
from reconf_dsl.ir import System
from reconf_dsl.loader import load, load_text

from .gen import SHAPES, generate, hub_component

FULL_MEASURED = 2_000_000


def _system(shape: str, n: int, seed: int) -> System:
    return load_text(generate(shape, n, seed, version=True), f"{shape}_{n}_{seed}.arch")


def _try(system: System, shape: str, n: int, strategy: str) -> Optional[Plan]:
    hub = hub_component(shape, n)
    try:
        return plan_replace(system, hub, hub + "_v2", strategy)
    except SearchTooLarge:
        return None
    except NoSafePlan:
        return None


def _systems(shapes: list[str], sizes: list[int], seed: int, tmp: str) -> Iterator[tuple[str, int, str]]:
    """Each shape at each size, with a new version of its hub declared, written to a file in `tmp`."""
    for shape in shapes:
        for n in sizes:
            path = os.path.join(tmp, f"{shape}_{n}.arch")
            with open(path, "w", encoding="utf-8") as f:
                f.write(generate(shape, n, seed, version=True))
            yield shape, n, path


def time_table(shapes: list[str], sizes: list[int], seed: int) -> bool:
    header = (f"{'shape':<6} {'N':>6} {'parse s':>8} {'plan s':>8} {'steps':>6} {'disruption':>11} "
              f"{'verify':>7} {'full s':>8} {'target':>6}")
    print("Table 1. replace the hub, default strategy")
    print(header)
    print("-" * len(header))
    ok_all = True
    with tempfile.TemporaryDirectory() as tmp:
        for shape, n, path in _systems(shapes, sizes, seed, tmp):
            t0 = time.perf_counter()
            system = load([path])
            t1 = time.perf_counter()
            hub = hub_component(shape, n)
            try:
                plan: Optional[Plan] = plan_replace(system, hub, hub + "_v2")
            except NoSafePlan as e:
                plan = None
                reason = e.reasons[0]
            t2 = time.perf_counter()
            if plan is None:
                print(f"{shape:<6} {n:>6} {t1 - t0:>8.3f} {t2 - t1:>8.3f}  no safe plan: {reason}")
                continue
            work = len(plan.states) * len(system.components)
            if work <= FULL_MEASURED:
                t3 = time.perf_counter()
                verify(system, plan.states[0], plan.steps, plan.goal, "default", full=True)
                full = f"{time.perf_counter() - t3:.2f}"
            else:
                t3 = time.perf_counter()
                evaluate(system, plan.states[-1], explain=False)
                full = f"~{(time.perf_counter() - t3) * len(plan.steps):.0f}"
            ok = t2 - t1 < 2 if n == 1000 else True
            ok_all &= ok
            print(f"{shape:<6} {n:>6} {t1 - t0:>8.3f} {t2 - t1:>8.3f} {len(plan.steps):>6} "
                  f"{plan.disruption:>11} {plan.verification:>7} {full:>8} {'ok' if ok else 'MISS':>6}",
                  flush=True)
    return ok_all


def _command(args: list[str], out: str) -> tuple[float, float, int]:
    """Wall seconds, peak resident MB and exit code of `reconf ARGS` in a fresh process."""
    reconf = os.path.join(os.path.dirname(sys.executable), "reconf")
    t0 = time.perf_counter()
    with open(out, "wb") as f:
        proc = subprocess.Popen([reconf, *args], stdout=f, stderr=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return time.perf_counter() - t0, usage.ru_maxrss / 1024, proc.returncode


def command_table(shapes: list[str], sizes: list[int], seed: int) -> bool:
    header = (f"{'shape':<6} {'N':>6} {'steps':>6} {'text s':>7} {'text MB':>8} {'json s':>7} {'json MB':>8} "
              f"{'json KB':>8} {'target':>6}")
    print("\nTable 4. reconf plan replace HUB --no-alloy, fresh process")
    print(header)
    print("-" * len(header))
    ok_all = True
    with tempfile.TemporaryDirectory() as tmp:
        for shape, n, path in _systems(shapes, sizes, seed, tmp):
            base = ["plan", "replace", hub_component(shape, n), "-f", path, "--no-alloy"]
            text_s, text_mb, code = _command(base, os.devnull)
            doc = os.path.join(tmp, "plan.json")
            json_s, json_mb, _ = _command(base + ["--output-format", "json"], doc)
            with open(doc, encoding="utf-8") as f:
                steps = len(json.load(f).get("plan", {}).get("steps", [])) if code == 0 else 0
            ok = code == 0 and (n < 10_000 or max(text_s, json_s) < 60 and max(text_mb, json_mb) < 1024)
            ok_all &= ok
            print(f"{shape:<6} {n:>6} {steps:>6} {text_s:>7.1f} {text_mb:>8.0f} {json_s:>7.1f} {json_mb:>8.0f} "
                  f"{os.path.getsize(doc) / 1024:>8.0f} {'ok' if ok else 'MISS':>6}", flush=True)
    return ok_all


def _cases(count: int, sizes: tuple[int, ...]) -> list[tuple[str, int, int]]:
    out: list[tuple[str, int, int]] = []
    seed = 0
    while len(out) < count:
        for n in sizes:
            for shape in SHAPES:
                if len(out) < count:
                    out.append((shape, n, seed))
        seed += 1
    return out


def quality_table(count: int) -> bool:
    """Default vs paper; False if default is ever worse."""
    n = equal = better = worse = unplanned = 0
    paper_failed = 0
    for shape, size, seed in _cases(count, (4, 6, 10, 20, 40)):
        system = _system(shape, size, seed)
        default = _try(system, shape, size, "default")
        paper = _try(system, shape, size, "paper")
        if default is None:
            unplanned += 1
            if paper is not None:
                worse += 1
                print(f"  default found no plan where paper did: {shape} {size} seed {seed}")
            continue
        n += 1
        if paper is None:
            paper_failed += 1
            better += 1
            continue
        if default.disruption < paper.disruption:
            better += 1
        elif default.disruption == paper.disruption:
            equal += 1
        else:
            worse += 1
            print(f"  default worse than paper: {shape} {size} seed {seed}: {default.disruption} > "
                  f"{paper.disruption}")
    header = f"{'systems':>8} {'planned':>8} {'equal':>12} {'better':>12} {'worse':>6} {'paper failed':>13}"
    print(f"\nTable 2. default vs paper, replace the hub, {count} systems of 4-40 components, all shapes")
    print(header)
    print("-" * len(header))
    print(f"{count:>8} {n:>8} {equal:>5} {_pct(equal, n):>6} {better:>5} {_pct(better, n):>6} {worse:>6} "
          f"{paper_failed:>13}")
    return worse == 0


def optimum_table(count: int) -> None:
    n = optimal = too_large = 0
    gaps = []
    for shape, size, seed in _cases(count, (3, 5, 8)):
        system = _system(shape, size, seed)
        best = _try(system, shape, size, "exhaustive")
        default = _try(system, shape, size, "default")
        if best is None or default is None:
            too_large += best is None and default is not None
            continue
        n += 1
        if default.disruption == best.disruption:
            optimal += 1
        else:
            gaps.append(default.disruption - best.disruption)
    header = f"{'systems':>8} {'compared':>9} {'default optimal':>16} {'mean gap':>9} {'search too large':>17}"
    print(f"\nTable 3. default vs the exhaustive optimum, replace the hub, {count} systems of 3-8 components")
    print(header)
    print("-" * len(header))
    gap = f"{sum(gaps) / len(gaps):.1f}" if gaps else "-"
    print(f"{count:>8} {n:>9} {optimal:>8} {_pct(optimal, n):>7} {gap:>9} {too_large:>17}")


def _pct(k: int, n: int) -> str:
    return f"{100 * k / n:.0f}%" if n else "-"


def profile(spec: str, seed: int, top: int) -> None:
    import cProfile
    import pstats

    shape, n = spec.split(":")
    system = _system(shape, int(n), seed)
    hub = hub_component(shape, int(n))
    prof = cProfile.Profile()
    prof.enable()
    plan_replace(system, hub, hub + "_v2")
    prof.disable()
    stats = pstats.Stats(prof, stream=sys.stdout)
    stats.sort_stats("cumulative").print_stats(top)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_plan", description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", default="fanin,dag,chain,tree", help="comma-separated, for table 1")
    ap.add_argument("--sizes", default="100,1000,10000", help="comma-separated component counts, for table 1")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quality", type=int, default=200, help="systems in table 2")
    ap.add_argument("--optimum", type=int, default=60, help="systems in table 3")
    ap.add_argument("--skip-time", action="store_true", help="only tables 2 and 3")
    ap.add_argument("--command", metavar="SIZES", default="1000,4000,10000",
                    help="comma-separated component counts for table 4 (fan-in and DAG); empty to skip")
    ap.add_argument("--profile", metavar="SHAPE:N", help="profile one replace with cProfile instead")
    ap.add_argument("--top", type=int, default=30)
    args = ap.parse_args(argv)
    if args.profile:
        profile(args.profile, args.seed, args.top)
        return 0
    shapes = [s.strip() for s in args.shapes.split(",") if s.strip()]
    for s in shapes:
        if s not in SHAPES:
            ap.error(f"unknown shape {s!r}; one of {', '.join(SHAPES)}")
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cpus")
    timely = True
    if not args.skip_time:
        timely = time_table(shapes, sorted(int(x) for x in args.sizes.split(",")), args.seed)
    if args.command:
        timely &= command_table(["fanin", "dag"], sorted(int(x) for x in args.command.split(",")), args.seed)
    never_worse = quality_table(args.quality)
    optimum_table(args.optimum)
    if not never_worse:
        print("\nFAIL: the default strategy was more disruptive than paper")
        return 1
    if not timely:
        print("\nMISS: 1,000 components not planned in under 2 s, or 10,000 not in 60 s and 1 GB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
