"""`reconf modes export` on generated architectures: shape x N.

    python -m bench.bench_modes [--shapes chain,dag] [--sizes 30,100,300] [--seed 0]

  modes   system modes exported (__DEFAULT__, DEGRADED, one per component and per functionality
          of a component with several)
  modes s computing them: what each degradation forces, then every mode checked valid in full
          (the full check is most of it: one evaluation of the whole system per mode)
  yaml s  writing the YAML
  size    of the YAML: every system mode names every part, so it grows as N²
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

from checker.reality.smh.export import export, render
from reconf_dsl.loader import Sources, load

from .gen import SHAPES, generate


def measure(shape: str, n: int, seed: int) -> tuple[int, float, float, int]:
    fd, path = tempfile.mkstemp(suffix=".arch")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(generate(shape, n, seed))
        system = load([path], Sources())
        t0 = time.perf_counter()
        exp = export(system)
        t1 = time.perf_counter()
        text = render(exp, system)
        t2 = time.perf_counter()
        return len(exp.modes), t1 - t0, t2 - t1, len(text.encode("utf-8"))
    finally:
        os.unlink(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", default="chain,dag")
    ap.add_argument("--sizes", default="30,100,300")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"{'shape':<7}{'N':>6}{'modes':>7}{'modes s':>9}{'yaml s':>8}{'size':>10}")
    for shape in args.shapes.split(","):
        assert shape in SHAPES, shape
        for n in (int(x) for x in args.sizes.split(",")):
            modes, t_modes, t_yaml, size = measure(shape, n, args.seed)
            print(f"{shape:<7}{n:>6}{modes:>7}{t_modes:>9.2f}{t_yaml:>8.2f}{size / 1024:>9.0f}K")


if __name__ == "__main__":
    main()
