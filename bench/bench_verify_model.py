"""Time every safety assertion of the meta-model at scopes 4, 5 and 6.

    python bench/bench_verify_model.py [--scopes 4,5,6] [--solver glucose]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from checker.alloy import AlloyBridge, metamodel_modules  # noqa: E402
from checker.alloy.metamodel import MAIN  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--scopes", default="4,5,6")
    parser.add_argument("--solver", default="glucose")
    args = parser.parse_args(argv)
    scopes = [int(s) for s in args.scopes.split(",")]
    bridge = AlloyBridge.get()
    solver = bridge.usable_solver(args.solver)
    labels = [label for label in bridge.commands(metamodel_modules(scopes[0]), MAIN)
              if label.startswith("Safe")]
    times: dict[tuple[str, int], float] = {}
    wrong: list[str] = []
    for scope in scopes:
        modules = metamodel_modules(scope)
        for label in labels:
            (o,) = bridge.run(modules, MAIN, label, solver)
            times[label, scope] = o.elapsed
            if not o.as_expected:
                wrong.append(f"{label}@{scope}")
            print(f"  {label} scope {scope}: {o.elapsed:.2f} s ({o.outcome})", file=sys.stderr, flush=True)
    width = max(len(label) for label in labels)
    print(f"solver: {solver}; machine: {_cpu()}; time includes translation to SAT")
    print(f"{'assertion':<{width}} " + " ".join(f"{'scope ' + str(s):>10}" for s in scopes))
    for label in labels:
        print(f"{label:<{width}} " + " ".join(f"{times[label, s]:>8.2f} s" for s in scopes))
    print(f"{'total':<{width}} " + " ".join(f"{sum(times[lab, s] for lab in labels):>8.2f} s" for s in scopes))
    if wrong:
        print("unexpected outcomes: " + ", ".join(wrong))
        return 1
    return 0


def _cpu() -> str:
    import os

    return f"{os.cpu_count()} CPUs"


if __name__ == "__main__":
    start = time.perf_counter()
    rc = main()
    print(f"wall time {time.perf_counter() - start:.1f} s", file=sys.stderr)
    sys.exit(rc)
