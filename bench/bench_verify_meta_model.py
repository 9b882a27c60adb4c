"""`reconf verify-meta-model` at several scopes: every command's time, the total against the
targets (scope 6 < 30 s, scope 7 < 120 s), and whether each check covers the paper's scope.

    python -m bench.bench_verify_meta_model [--scopes 5,6,7] [--solver glucose41]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from checker.alloy.bridge import DEFAULT_SOLVER
from checker.alloy.verify_meta_model import VerifyReport, verify_meta_model

TARGETS = {6: 30.0, 7: 120.0}   # seconds for every command of the meta-model


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scopes", default="5,6,7", help="comma-separated scopes of the checks")
    parser.add_argument("--solver", default=DEFAULT_SOLVER)
    args = parser.parse_args(argv)
    scopes = [int(s) for s in args.scopes.split(",")]
    reports: dict[int, VerifyReport] = {}
    walls: dict[int, float] = {}
    for scope in scopes:
        start = time.perf_counter()
        reports[scope] = verify_meta_model(scope, args.solver)
        walls[scope] = time.perf_counter() - start
        print(f"  scope {scope}: {walls[scope]:.1f} s by {reports[scope].processes} processes",
              file=sys.stderr, flush=True)
    first = reports[scopes[0]]
    print(f"solver {first.solver}; {os.cpu_count()} CPUs, {first.processes} analyzer processes; a command's time "
          "includes its translation to SAT; runs keep scope 3; the wall time includes parsing and the "
          "helper process's start")
    print()
    print("| command | " + " | ".join(f"scope {s}" for s in scopes) + " |")
    print("|---|" + "---|" * len(scopes))
    for i, row in enumerate(first.rows):
        print(f"| {row.command} | " + " | ".join(f"{reports[s].rows[i].seconds:.2f}" for s in scopes) + " |")
    print("| **all commands, wall s** | " + " | ".join(f"**{walls[s]:.1f}**" for s in scopes) + " |")
    print("| target | " + " | ".join(f"< {TARGETS[s]:.0f}" if s in TARGETS else "-" for s in scopes) + " |")
    print("| covers the paper's for 5 | " + " | ".join("yes" if not reports[s].below_paper() else "no"
                                                      for s in scopes) + " |")
    wrong = [f"{r.command}@{s}" for s in scopes for r in reports[s].rows if r.as_expected is False]
    missed = [f"scope {s}: {walls[s]:.1f} s" for s in scopes if s in TARGETS and walls[s] >= TARGETS[s]]
    if wrong:
        print("unexpected outcomes: " + ", ".join(wrong))
    if missed:
        print("targets missed: " + ", ".join(missed))
    return 1 if wrong or missed else 0


if __name__ == "__main__":
    sys.exit(main())
