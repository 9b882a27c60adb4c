"""Parse and check time, and memory, of generated architectures: shape x N.

    python -m bench.bench_check [--shapes chain,dag] [--sizes 100,1000,10000] [--seed 0]
                                [--repeat 1] [--profile SHAPE:N]

Each case is generated in this process, written to a temporary .arch file, then loaded
and checked in a fresh Python process, so that timings do not share caches or garbage
and the memory figure is that case's own:

  parse  `reconf_dsl.loader.load([path])` (read, parse, resolve)
  check  `checker.semantic_model.semantics.evaluate(system, Configuration.initial(system))`
  peak   resource.getrusage(RUSAGE_SELF).ru_maxrss of that process after checking, in MiB,
         minus its maxrss after the imports (the interpreter, lark, networkx): the growth
         due to the case itself. tracemalloc is not used: it slows Python 2-3x.
  growth (parse + check at N) / (parse + check at N/10), when N/10 was measured too.

Targets: 1,000 components parsed+checked < 1 s, 10,000 < 10 s, growth <= 12x.
`--profile SHAPE:N` runs one case under cProfile and prints the top functions.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from typing import Any

from .gen import SHAPES, generate

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHILD = r"""
import json, resource, sys, time
from reconf_dsl.loader import load
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
path = sys.argv[1]
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
system = load([path])
t1 = time.perf_counter()
ev = evaluate(system, Configuration.initial(system))
valid = ev.valid
t2 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"parse": t1 - t0, "check": t2 - t1, "base_kib": base, "peak_kib": peak,
                  "valid": valid, "components": len(system.components),
                  "connectors": len(system.connectors), "unsatisfied": len(ev.unsatisfied)}))
"""


def run_case(path: str) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", CHILD, path], capture_output=True, text=True, env=env, cwd=ROOT)
    if proc.returncode != 0:
        raise RuntimeError(f"checking {path} failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def measure(shape: str, n: int, seed: int, repeat: int, tmp: str) -> dict[str, Any]:
    text = generate(shape, n, seed)
    path = os.path.join(tmp, f"{shape}_{n}.arch")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    runs = [run_case(path) for _ in range(repeat)]
    best = min(runs, key=lambda r: r["parse"] + r["check"])
    best["bytes"] = os.path.getsize(path)
    return best


def _size(b: int) -> str:
    return f"{b / 1024:.0f} KiB" if b < 1024 * 1024 else f"{b / 1024 / 1024:.1f} MiB"


def profile(spec: str, seed: int, top: int) -> None:
    import cProfile
    import pstats

    from checker.semantic_model.config import Configuration
    from checker.semantic_model.semantics import evaluate
    from reconf_dsl.loader import load

    shape, n = spec.split(":")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, f"{shape}_{n}.arch")
        with open(path, "w", encoding="utf-8") as f:
            f.write(generate(shape, int(n), seed))
        prof = cProfile.Profile()
        prof.enable()
        system = load([path])
        evaluate(system, Configuration.initial(system))
        prof.disable()
    stats = pstats.Stats(prof, stream=sys.stdout)
    stats.sort_stats("tottime").print_stats(top)
    stats.sort_stats("cumulative").print_stats(top)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_check", description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", default=",".join(SHAPES), help="comma-separated, default: all")
    ap.add_argument("--sizes", default="100,1000,10000", help="comma-separated component counts")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=1, help="runs per case; the fastest is reported")
    ap.add_argument("--profile", metavar="SHAPE:N", help="profile one case with cProfile instead")
    ap.add_argument("--top", type=int, default=25, help="functions shown by --profile")
    args = ap.parse_args(argv)
    if args.profile:
        profile(args.profile, args.seed, args.top)
        return 0
    shapes = [s.strip() for s in args.shapes.split(",") if s.strip()]
    for s in shapes:
        if s not in SHAPES:
            ap.error(f"unknown shape {s!r}; one of {', '.join(SHAPES)}")
    sizes = sorted(int(x) for x in args.sizes.split(","))
    header = (f"{'shape':<6} {'N':>6} {'file':>9} {'parse s':>8} {'check s':>8} {'total s':>8} "
              f"{'peak MiB':>9} {'verdict':>7} {'growth':>7} {'target':>6}")
    print(f"peak = ru_maxrss growth over the process after imports (getrusage, fresh process per case); "
          f"python {sys.version.split()[0]}, {os.cpu_count()} cpus")
    print(header)
    print("-" * len(header))
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        for shape in shapes:
            totals: dict[int, float] = {}
            for n in sizes:
                r = measure(shape, n, args.seed, args.repeat, tmp)
                total = r["parse"] + r["check"]
                totals[n] = total
                growth = f"{total / totals[n // 10]:.1f}x" if n // 10 in totals else "-"
                ok = total < n / 1000 if n >= 1000 else True
                if n // 10 in totals:
                    ok = ok and total / totals[n // 10] <= 12
                failed |= not ok
                verdict = "safe" if r["valid"] else "UNSAFE"
                peak = (r["peak_kib"] - r["base_kib"]) / 1024
                print(f"{shape:<6} {n:>6} {_size(r['bytes']):>9} {r['parse']:>8.3f} {r['check']:>8.3f} "
                      f"{total:>8.3f} {peak:>9.1f} {verdict:>7} {growth:>7} {'ok' if ok else 'MISS':>6}",
                      flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
