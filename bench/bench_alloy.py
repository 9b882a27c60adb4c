"""Alloy timings: `reconf check --engine alloy` and plan verification on generated systems.

    python -m bench.bench_alloy [--check-sizes 50,200,1000] [--plan-sizes 100,1000]
                                [--shapes fanin,chain,tree,dag,cycle] [--repeat 3]
                                [--timeout 600]

Table (a): for each shape and size, `reconf check --engine alloy` on a generated
architecture in a fresh process (wall time, JVM start included; the median of --repeat
runs), and, in another fresh process, the same work split: JVM start (import and start
of the bridge), alloy (render, parse and judge every slice: `alloy_verdict`), of which
solve (the analyzer's commands), and the number of slices (modules) judged.
Table (b): the `fanin` system with `hub_v2 replaces hub`, planned with
`plan_replace(system, "hub", "hub_v2")`, then `alloy_plan_verdict` over the plan's states:
render, parse, solve (evaluation of the verdict included) and total (one call of
alloy_plan_verdict, render to verdict).
A case that fails or runs past --timeout shows the reason instead of figures.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any

from .gen import generate

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHECK_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
from reconf_dsl.loader import load
from checker.config import Configuration
from checker.alloy import AlloyBridge
from checker.alloy.instance import alloy_verdict, slices
system = load([sys.argv[1]])
bridge = AlloyBridge.get()
t1 = time.perf_counter()
config = Configuration.initial(system)
verdict = alloy_verdict(system, config, bridge=bridge)
t2 = time.perf_counter()
print(json.dumps({"start": t1 - t0, "alloy": t2 - t1, "solve": verdict.seconds,
                  "slices": len(slices(system, config) or [None]), "valid": verdict.valid}))
"""

PLAN_CHILD = r"""
import json, sys, time
from reconf_dsl.loader import load
from checker.alloy import AlloyBridge
from checker.alloy.instance import PLAN_MAIN, alloy_plan_verdict
from checker.planning import plan_replace
from codegen.alloy import render_plan
system = load([sys.argv[1]])
bridge = AlloyBridge.get()
t0 = time.perf_counter()
plan = plan_replace(system, "hub", "hub_v2")
t1 = time.perf_counter()
text, _ = render_plan(system, plan.states)
t2 = time.perf_counter()
bridge.commands({PLAN_MAIN: text}, PLAN_MAIN)
t3 = time.perf_counter()
verdict = alloy_plan_verdict(system, plan.states, bridge=bridge)
t4 = time.perf_counter()
# alloy_plan_verdict renders, parses, solves and reads the verdict; `parse` is timed on its
# own beforehand, and `solve` is the rest
print(json.dumps({"plan": t1 - t0, "steps": len(plan.steps), "render": t2 - t1, "parse": t3 - t2,
                  "solve": (t4 - t3) - (t3 - t1), "total": t4 - t3, "ok": verdict.ok}))
"""


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _child(code: str, path: str, timeout: float) -> dict[str, Any]:
    try:
        proc = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True,
                              env=_env(), cwd=ROOT, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"over {timeout:g} s"}
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["failed"])[-1]
        return {"error": last[:90]}
    return json.loads(proc.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def _cli_wall(path: str, timeout: float) -> tuple[float, str]:
    """Wall seconds of `reconf check --engine alloy` in a fresh process, and a note
    ("" when it exited 0 or 1)."""
    reconf = os.path.join(os.path.dirname(sys.executable), "reconf")
    cmd = [reconf] if os.path.exists(reconf) else [sys.executable, "-m", "checker.cli"]
    start = time.perf_counter()
    try:
        proc = subprocess.run(cmd + ["check", "--engine", "alloy", path], capture_output=True, text=True,
                              env=_env(), cwd=ROOT, timeout=timeout)
    except subprocess.TimeoutExpired:
        return float("inf"), f"> {timeout:g} s"
    wall = time.perf_counter() - start
    return wall, ("" if proc.returncode in (0, 1) else f"exit {proc.returncode}")


def _write(shape: str, n: int, version: bool, tmp: str) -> str:
    path = os.path.join(tmp, f"{shape}_{n}.arch")
    with open(path, "w", encoding="utf-8") as f:
        f.write(generate(shape, n, 1, version=version))
    return path


def _s(row: dict[str, Any], key: str) -> str:
    return f"{row[key]:.2f}" if key in row else "-"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_alloy")
    parser.add_argument("--check-sizes", default="50,200,1000")
    parser.add_argument("--plan-sizes", default="100,1000")
    parser.add_argument("--shapes", default="fanin,chain,tree,dag,cycle")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=600)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        print("(a) reconf check --engine alloy (seconds; wall = fresh process, median of "
              f"{args.repeat}; target: 200 components < 3 s)")
        print(f"{'shape':<7}{'N':>6} {'wall':>10} {'JVM start':>10} {'alloy':>8} {'solve':>8} {'slices':>7}  verdict")
        for shape in (x for x in args.shapes.split(",") if x):
            for n in (int(x) for x in args.check_sizes.split(",") if x):
                path = _write(shape, n, False, tmp)
                walls = sorted(_cli_wall(path, args.timeout) for _ in range(max(1, args.repeat)))
                seconds, note = walls[len(walls) // 2]
                wall = note if seconds == float("inf") else f"{seconds:.2f} s" + (f" ({note})" if note else "")
                row = _child(CHECK_CHILD, path, args.timeout)
                verdict = row.get("error") or ("valid" if row["valid"] else "not valid")
                print(f"{shape:<7}{n:>6} {wall:>10} {_s(row, 'start'):>10} {_s(row, 'alloy'):>8} "
                      f"{_s(row, 'solve'):>8} {row.get('slices', '-'):>7}  {verdict}", flush=True)
        print()
        print("(b) Alloy verification of the plan replacing hub by hub_v2, shape fanin (seconds)")
        print(f"{'N':>6} {'steps':>6} {'render':>8} {'parse':>8} {'solve':>8} {'total':>8}  verdict")
        for n in (int(x) for x in args.plan_sizes.split(",") if x):
            path = _write("fanin", n, True, tmp)
            row = _child(PLAN_CHILD, path, args.timeout)
            verdict = row.get("error") or ("accepted" if row["ok"] else "refused")
            steps = str(row.get("steps", "-"))
            print(f"{n:>6} {steps:>6} {_s(row, 'render'):>8} {_s(row, 'parse'):>8} {_s(row, 'solve'):>8} "
                  f"{_s(row, 'total'):>8}  {verdict}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
