"""Mutation fuzzing of the command line: mutants of the bundled examples, run through
`reconf check` (Python engine; one in 50 also with the Alloy proof), `fmt`, `alloy`, `graph` and
`plan remove` in this process; every outcome must keep the
exit-code contract (docs/exit-codes.md): 0, 1 or 2, never a traceback, never RC000, and
valid JSON on stdout whenever JSON was asked for.

    python -m bench.fuzz [--mutants 5000] [--seed 0]

`mutants(seed)` is shared with tests/test_fuzz.py, which runs a few hundred of them.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import random
import re
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from typing import Callable, Iterator, Optional

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLES = os.path.join(ROOT, "examples")

# what a mutation inserts: the language's own words and signs, and what breaks lexers
VOCABULARY = [b"system", b"component", b"functionality", b"normal", b"degraded", b"assume", b"input", b"output",
              b"topic", b"service", b"single", b"include", b"message", b"host", b"ftm", b"faults", b"nothing",
              b"replaces", b"criticality", b"environment", b"{", b"}", b"(", b")", b":", b",", b"->", b"@", b"=",
              b'"', b"//", b"/*", b"*/", b"Hz", b"kHz", b"0", b"-1", b"1e309", b"99999999999999999999",
              b"0.0000001", b"PBR(", b"LFR", b"TR", b"\x00", b"\r", b"\t", b"\xff\xfe", "Ω".encode(),
              b"\xe2\x80\xae", b'include "/dev/zero"', b'include "../../../etc/passwd"', b"\n" * 3]


def _delete(rng: random.Random, data: bytes) -> bytes:
    i = rng.randrange(len(data) + 1)
    return data[:i] + data[i + rng.randint(1, 40):]


def _insert(rng: random.Random, data: bytes) -> bytes:
    i = rng.randrange(len(data) + 1)
    word = rng.choice(VOCABULARY)
    return data[:i] + (b" " if rng.random() < 0.5 else b"") + word + b" " + data[i:]


def _byte(rng: random.Random, data: bytes) -> bytes:
    if not data:
        return bytes([rng.randrange(256)])
    i = rng.randrange(len(data))
    return data[:i] + bytes([rng.randrange(256)]) + data[i + 1:]


def _lines(rng: random.Random, data: bytes) -> bytes:
    lines = data.split(b"\n")
    i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
    if rng.random() < 0.5:
        lines[i], lines[j] = lines[j], lines[i]
    else:
        lines.insert(j, lines[i])
    return b"\n".join(lines)


def _truncate(rng: random.Random, data: bytes) -> bytes:
    return data[:rng.randrange(len(data) + 1)]


def _nest(rng: random.Random, data: bytes) -> bytes:
    depth = rng.choice([50, 500, 5000])
    i = rng.randrange(len(data) + 1)
    inner = rng.choice([b"{" * depth + b"}" * depth, b"PBR(" * depth + b"TR" + b")" * depth, b"(" * depth,
                        b"/*" * depth + b"*/" * depth])
    return data[:i] + inner + data[i:]


def _rename(rng: random.Random, data: bytes) -> bytes:
    """One name used in place of another: stays parseable, breaks references and types."""
    names = re.findall(rb"\b[A-Za-z_/][\w/]*\b", data)
    if len(names) < 2:
        return data
    a, b = rng.choice(names), rng.choice(names)
    spots = [m.start() for m in re.finditer(re.escape(a), data)]
    i = rng.choice(spots)
    return data[:i] + b + data[i + len(a):]


def _number(rng: random.Random, data: bytes) -> bytes:
    spots = list(re.finditer(rb"\d+(\.\d+)?", data))
    if not spots:
        return data
    m = rng.choice(spots)
    return data[:m.start()] + rng.choice([b"0", b"1", b"3", b"1000000", b"0.5", b"999999999999", b"0.001"]) + data[m.end():]


def _drop_line(rng: random.Random, data: bytes) -> bytes:
    lines = data.split(b"\n")
    del lines[rng.randrange(len(lines))]
    return b"\n".join(lines)


def _splice(rng: random.Random, data: bytes, other: bytes) -> bytes:
    a, b = data.split(b"\n"), other.split(b"\n")
    i, j = rng.randrange(len(a) + 1), rng.randrange(len(b))
    return b"\n".join(a[:i] + b[j:j + rng.randint(1, 8)] + a[i:])


# the ones that keep the text parseable more often come twice
MUTATIONS: list[Callable[[random.Random, bytes], bytes]] = [_delete, _insert, _byte, _lines, _truncate, _nest, _rename,
                                                            _rename, _number, _number, _drop_line, _drop_line]


def sources() -> list[tuple[str, bytes]]:
    """The bundled examples (relative path, bytes), the seeds of every mutant."""
    out = []
    for path in sorted(glob.glob(os.path.join(EXAMPLES, "**", "*.arch"), recursive=True)):
        with open(path, "rb") as f:
            out.append((os.path.relpath(path, EXAMPLES), f.read()))
    return out


def mutants(seed: int, count: int) -> Iterator[tuple[str, bytes]]:
    """`count` mutants: (the example it came from, its bytes), one to four mutations each."""
    rng = random.Random(seed)
    seeds = sources()
    for _ in range(count):
        name, data = rng.choice(seeds)
        for _ in range(rng.choice([1, 1, 1, 1, 2, 2, 3, 4])):
            if rng.random() < 0.1:
                data = _splice(rng, data, rng.choice(seeds)[1])
            else:
                data = rng.choice(MUTATIONS)(rng, data)
        yield name, data


@dataclass
class Tally:
    runs: int = 0
    by_exit: dict[int, int] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    slowest: float = 0.0

    def add(self, what: str, code: int, stdout: str, stderr: str, exception: Optional[BaseException],
            want_json: bool, seconds: float) -> None:
        self.runs += 1
        self.by_exit[code] = self.by_exit.get(code, 0) + 1
        self.slowest = max(self.slowest, seconds)
        wrong = []
        if code not in (0, 1, 2):
            wrong.append(f"exit {code}")
        if exception is not None and not isinstance(exception, SystemExit):
            wrong.append(f"escaped {type(exception).__name__}: {exception}")
        if "Traceback" in stdout + stderr:
            wrong.append("a traceback")
        if "RC000" in stdout + stderr:
            wrong.append("an internal error (RC000)")
        if want_json and code in (0, 1, 2) and stdout.strip():
            try:
                json.loads(stdout)
            except ValueError:
                wrong.append("stdout is not JSON")
        if wrong:
            self.failures.append(f"{what}: {', '.join(wrong)}\n{stderr[-600:]}")


def run(seed: int, count: int, tally: Tally, progress: Optional[Callable[[int], None]] = None) -> Tally:
    """Run `count` mutants through the commands; count what breaks the contract."""
    from click.testing import CliRunner

    from checker.cli.main import main
    os.environ.pop("RECONF_DEBUG", None)
    runner = CliRunner()
    with tempfile.TemporaryDirectory() as tmp:
        tree = os.path.join(tmp, "examples")
        shutil.copytree(EXAMPLES, tree)
        for k, (name, data) in enumerate(mutants(seed, count)):
            path = os.path.join(tree, os.path.dirname(name), f"mutant_{k}.arch")
            with open(path, "wb") as f:
                f.write(data)
            commands = [["check", "--engine", "python", "--output-format", "json", path], ["fmt", "--check", path]]
            if k % 5 == 0:
                commands += [["alloy", path], ["graph", "--format", "mermaid", path]]
            if k % 50 == 0:                     # the default check: the proof in the Alloy Analyzer
                commands.append(["check", "--output-format", "sarif", path])
            if k % 10 == 0:
                named = re.search(rb"component\s+(\w+)", data)
                target = named[1].decode("utf-8", "replace") if named else "talker"
                commands.append(["plan", "remove", target, "-f", path, "--no-alloy", "--output-format", "json"])
            for args in commands:
                t0 = time.perf_counter()
                r = runner.invoke(main, args)
                tally.add(f"mutant {k} of {name} ({seed=}), reconf {' '.join(args[:2])}", r.exit_code, r.stdout,
                          r.stderr, r.exception, "json" in args, time.perf_counter() - t0)
            os.unlink(path)
            if progress is not None:
                progress(k + 1)
    return tally


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.fuzz", description=__doc__.split("\n\n")[0])
    ap.add_argument("--mutants", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()

    def progress(k: int) -> None:
        if k % 500 == 0:
            print(f"  {k} mutants, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)

    tally = run(args.seed, args.mutants, Tally(), progress)
    wall = time.perf_counter() - t0
    print(f"{'mutants':>8} {'runs':>6} {'exit 0':>7} {'exit 1':>7} {'exit 2':>7} {'other':>6} {'broken':>7} "
          f"{'slowest s':>10} {'wall s':>7}")
    other = sum(n for c, n in tally.by_exit.items() if c not in (0, 1, 2))
    print(f"{args.mutants:>8} {tally.runs:>6} {tally.by_exit.get(0, 0):>7} {tally.by_exit.get(1, 0):>7} "
          f"{tally.by_exit.get(2, 0):>7} {other:>6} {len(tally.failures):>7} {tally.slowest:>10.2f} {wall:>7.0f}")
    for f in tally.failures[:20]:
        print("\n" + f)
    return 1 if tally.failures else 0


if __name__ == "__main__":
    sys.exit(main())
