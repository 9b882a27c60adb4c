"""The default path as a user runs it: `reconf check FILE` and `reconf plan replace HUB -f FILE`,
each a fresh process, the wall time measured from outside.

    python -m bench.bench_default [--shapes dag,chain,tree,fanin,cycle] [--sizes 1000,2000,5000,10000,20000]
                                  [--plan-seeds 10] [--plan-size 1000] [--repeat 1]

Table (a): the default `reconf check` (the Python engine and the Alloy proof) per shape and
size: wall time, and where the time went as the command's own JSON `timing` says (parsing,
the Python engine, Alloy's start, rendering the modules, the analyzer), and the growth per
doubling of size, (wall(N) / wall(M)) ** (1 / log2(N / M)) for the previous size M.
Targets: 1,000 components < 1.5 s, 10,000 < 10 s, 20,000 < 20 s, growth per doubling <= 2.2.

Table (b): `reconf plan replace HUB` with its Alloy verification (the default), for
`--plan-seeds` seeds per shape at `--plan-size` components: wall time (median / max) and
steps. Target: < 5 s for every shape and seed at 1,000 components.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

from .gen import SHAPES, generate, hub_component

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHECK_TARGETS = {1000: 1.5, 10000: 10.0, 20000: 20.0}
GROWTH_TARGET = 2.2
PLAN_TARGET = 5.0


def _reconf(args: list[str]) -> tuple[float, int, str]:
    """Run `reconf ARGS` in a fresh process: wall seconds, exit status, stdout."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), RECONF_NO_PROGRESS="1")
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "checker", *args], capture_output=True, text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"reconf {' '.join(args)} exited {proc.returncode}:\n{proc.stderr[-2000:]}")
    return wall, proc.returncode, proc.stdout


def check_row(path: str) -> dict[str, Any]:
    wall, code, out = _reconf(["check", path, "--output-format", "json"])
    doc = json.loads(out)
    alloy = doc.get("engines", {}).get("alloy", {}).get("timing", {})
    return {"wall": wall, "verdict": doc["verdict"], "timing": doc.get("timing", {}), "alloy": alloy}


def plan_row(path: str, hub: str) -> dict[str, Any]:
    wall, code, out = _reconf(["plan", "replace", hub, "-f", path, "--output-format", "json"])
    doc = json.loads(out)
    alloy = doc.get("evidence", {}).get("alloy", {})
    return {"wall": wall, "code": code, "steps": len(doc.get("plan", {}).get("steps", [])),
            "verified": bool(alloy.get("valid"))}


def _growth(walls: dict[int, float], n: int) -> float | None:
    smaller = [m for m in walls if m < n]
    if not smaller:
        return None
    m = max(smaller)
    return (walls[n] / walls[m]) ** (1 / math.log2(n / m))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_default", description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", default="dag,chain,tree,fanin,cycle")
    ap.add_argument("--sizes", default="1000,2000,5000,10000,20000")
    ap.add_argument("--seed", type=int, default=1, help="the seed of table (a)'s systems")
    ap.add_argument("--repeat", type=int, default=1, help="runs per check case; the fastest is reported")
    ap.add_argument("--plan-seeds", type=int, default=10, help="seeds per shape in table (b); 0: no table (b)")
    ap.add_argument("--plan-size", type=int, default=1000)
    args = ap.parse_args(argv)
    shapes = [s.strip() for s in args.shapes.split(",") if s.strip()]
    for s in shapes:
        if s not in SHAPES:
            ap.error(f"unknown shape {s!r}; one of {', '.join(SHAPES)}")
    sizes = sorted(int(x) for x in args.sizes.split(",") if x.strip())
    missed = False
    print(f"(a) default `reconf check`, a fresh process per case (python {sys.version.split()[0]}, "
          f"{os.cpu_count()} cpus; seconds; growth per doubling of N)")
    print("| shape | N | wall | start-up | parsing | Python engine | Alloy start | rendering | Alloy | instances | "
          "growth | target |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for shape in shapes:
            walls: dict[int, float] = {}
            for n in sizes:
                path = os.path.join(tmp, f"{shape}_{n}.arch")
                with open(path, "w", encoding="utf-8") as f:
                    f.write(generate(shape, n, args.seed))
                row = min((check_row(path) for _ in range(args.repeat)), key=lambda r: r["wall"])
                walls[n] = row["wall"]
                growth = _growth(walls, n)
                ok = (row["wall"] < CHECK_TARGETS.get(n, math.inf)) and (growth is None or growth <= GROWTH_TARGET)
                missed |= not ok
                t, al = row["timing"], row["alloy"]
                cells = [f"{t.get(k, 0):.2f}" for k in ("start_up", "parsing", "python_engine", "alloy_start",
                                                        "rendering", "alloy")]
                print(f"| {shape} | {n} | {row['wall']:.2f} | " + " | ".join(cells) +
                      f" | {al.get('instances', '-')} | "
                      f"{'-' if growth is None else f'{growth:.2f}x'} | {'ok' if ok else 'MISS'} |", flush=True)
        if args.plan_seeds:
            print(f"\n(b) `reconf plan replace HUB` with Alloy verification, {args.plan_size} components, "
                  f"seeds 0-{args.plan_seeds - 1} (seconds; target < {PLAN_TARGET:.0f} s every seed)")
            print("| shape | seeds | verified | wall median | wall max | slowest seed | steps median | steps max | target |")
            print("|---|---|---|---|---|---|---|---|---|")
            n = args.plan_size
            for shape in shapes:
                rows = []
                for seed in range(args.plan_seeds):
                    path = os.path.join(tmp, f"plan_{shape}_{n}_{seed}.arch")
                    with open(path, "w", encoding="utf-8") as f:
                        f.write(generate(shape, n, seed, version=True))
                    rows.append((seed, plan_row(path, hub_component(shape, n))))
                walls_p = [r["wall"] for _, r in rows]
                steps = [r["steps"] for _, r in rows]
                slowest = max(rows, key=lambda sr: sr[1]["wall"])[0]
                ok = max(walls_p) < PLAN_TARGET and all(r["code"] == 0 and r["verified"] for _, r in rows)
                missed |= not ok
                verified = sum(r["verified"] for _, r in rows)
                print(f"| {shape} | {len(rows)} | {verified} | {statistics.median(walls_p):.2f} | {max(walls_p):.2f} | {slowest} | "
                      f"{statistics.median(steps):.0f} | {max(steps)} | {'ok' if ok else 'MISS'} |", flush=True)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
