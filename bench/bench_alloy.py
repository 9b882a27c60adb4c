"""Alloy timings: `reconf check --engine alloy` and plan verification on generated systems.

    python -m bench.bench_alloy [--check-sizes 50,200,1000] [--plan-sizes 100,1000]
                                [--shapes fanin,chain,tree,dag,cycle] [--repeat 3]
                                [--timeout 600]

Table (a): for each shape and size, `reconf check --engine alloy` on a generated
architecture in a fresh process (wall time, JVM start included; the median of --repeat
runs), and, in another fresh process, the same work split: JVM start (import and start
of the bridge), alloy (write every slice as an instance, have the analyzer read it and
evaluate in it: `alloy_verdict`), of which eval (the analyzer's evaluating), and the number
of slices (instances) judged.
Table (b): for each shape and size, the system of bench_plan (seed 0, its hub with a
version), the hub replaced with `plan_replace`, then the plan verified as `reconf plan`
does, with `checker.planning.alloy_verify.alloy_evidence`: the plan in windows of consecutive steps,
each module on the slice its window can affect (lean first), then every other component
judged once in the first state. Columns: plan time, Alloy time (JVM start excluded), of
which the analyzer's commands, the windows, the largest window's slice (components and
kind), the components judged once, and the verdict (a one-step module beyond
`alloy_plan.MODULE_BUDGET` state-components is not run).
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
from checker.semantic_model.config import Configuration
from checker.alloy import get_backend
from checker.alloy.instance import alloy_verdict, slices
system = load([sys.argv[1]])
bridge = get_backend()
t1 = time.perf_counter()
config = Configuration.initial(system)
verdict = alloy_verdict(system, config, bridge=bridge)
t2 = time.perf_counter()
print(json.dumps({"start": t1 - t0, "alloy": t2 - t1, "eval": verdict.seconds,
                  "slices": len(slices(system, config) or [None]), "valid": verdict.valid}))
"""

PLAN_CHILD = r"""
import json, sys, time
from bench.gen import hub_component
from reconf_dsl.loader import load
from checker.alloy import get_backend
from checker.planning.alloy_verify import alloy_evidence
from checker.planning import plan_replace
system = load([sys.argv[1]])
shape, n = sys.argv[2], int(sys.argv[3])
bridge = get_backend()
hub = hub_component(shape, n)
t0 = time.perf_counter()
plan = plan_replace(system, hub, hub + "_v2")
t1 = time.perf_counter()
ev = alloy_evidence(plan)
t2 = time.perf_counter()
sl = ev.get("slice", {})
print(json.dumps({"plan": t1 - t0, "steps": len(plan.steps), "alloy": t2 - t1, "eval": ev["seconds"],
                  "slice": sl.get("components"), "kind": sl.get("kind", "whole"), "once": sl.get("judged_once", 0),
                  "windows": sl.get("windows", 1),
                  "ok": ev["valid"], "reason": ev.get("reason", ""), "not_run": ev.get("verdict") == "not run"}))
"""


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _child(code: str, path: str, timeout: float, *args: str) -> dict[str, Any]:
    try:
        proc = subprocess.run([sys.executable, "-c", code, path, *args], capture_output=True, text=True,
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
    cmd = [reconf] if os.path.exists(reconf) else [sys.executable, "-m", "checker"]
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
        print(f"{'shape':<7}{'N':>6} {'wall':>10} {'JVM start':>10} {'alloy':>8} {'eval':>8} {'slices':>7}  verdict")
        for shape in (x for x in args.shapes.split(",") if x):
            for n in (int(x) for x in args.check_sizes.split(",") if x):
                path = _write(shape, n, False, tmp)
                walls = sorted(_cli_wall(path, args.timeout) for _ in range(max(1, args.repeat)))
                seconds, note = walls[len(walls) // 2]
                wall = note if seconds == float("inf") else f"{seconds:.2f} s" + (f" ({note})" if note else "")
                row = _child(CHECK_CHILD, path, args.timeout)
                verdict = row.get("error") or ("valid" if row["valid"] else "not valid")
                print(f"{shape:<7}{n:>6} {wall:>10} {_s(row, 'start'):>10} {_s(row, 'alloy'):>8} "
                      f"{_s(row, 'eval'):>8} {row.get('slices', '-'):>7}  {verdict}", flush=True)
        print()
        print("(b) Alloy verification of the plan replacing the hub (bench_plan's plans, seed 0; seconds;\n"
              "    target: 1,000 components verified < 10 s): plan = plan_replace, alloy = alloy_evidence\n"
              "    (the plan's windows of steps, each module on the slice it can affect, then every other\n"
              "    component judged once), of which eval; slice = the largest window's components")
        print(f"{'shape':<7}{'N':>6} {'steps':>6} {'plan':>7} {'alloy':>7} {'eval':>7} {'windows':>8} {'slice':>10} "
              f"{'once':>6}  verdict")
        for shape in (x for x in args.shapes.split(",") if x):
            for n in (int(x) for x in args.plan_sizes.split(",") if x):
                path = os.path.join(tmp, f"{shape}_{n}_v.arch")
                with open(path, "w", encoding="utf-8") as f:
                    f.write(generate(shape, n, 0, version=True))
                row = _child(PLAN_CHILD, path, args.timeout, shape, str(n))
                if "error" in row:
                    verdict = row["error"]
                elif row["not_run"]:
                    verdict = "not run: too large"
                else:
                    verdict = "verified" if row["ok"] else f"refused: {row['reason'][:60]}"
                sl = f"{row.get('slice', '-')} {row.get('kind', '')}" if row.get("slice") else row.get("kind", "-")
                print(f"{shape:<7}{n:>6} {str(row.get('steps', '-')):>6} {_s(row, 'plan'):>7} {_s(row, 'alloy'):>7} "
                      f"{_s(row, 'eval'):>7} {str(row.get('windows', '-')):>8} {sl:>10} {str(row.get('once', '-')):>6}"
                      f"  {verdict}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
