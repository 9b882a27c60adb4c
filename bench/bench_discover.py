"""`reconf discover` and `reconf drift` on generated live systems (docs/runtime.md#discover).

For each size (default 10, 50, 100 components): a `bench.gen` architecture (shape dag) with
every rate set to 2 Hz, so that the nodes' traffic does not swamp two cores, deployed as
model-driven nodes ten per process (two more in processes of their own). Measures the wall
time of `reconf discover` and `reconf drift` (the command, start-up included) and where it
went: waiting for discovery to settle, reading every node (both from the snapshot's own
clock), and the rest (Python start-up, rclpy.init, parsing, comparing or writing). Then, on the largest system, 20
differences made on the live system, every kind of `reconf drift`: how many it finds, and
whether it reports anything on the unchanged system.

    python -m bench.bench_discover [--sizes 10,50,100] [--settle 15] [--no-bag]

It ends with `bench.bench_bag`: `reconf check --bag` on 1/4, 1/2 and 1 GiB recordings, wall
time and peak memory (streaming: memory independent of the recording's length).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

from bench.gen import generate
from reconf_dsl.loader import load, load_text
from reconf_ros.tools.livetest import LiveSystem

RATE = re.compile(r"@\s*[0-9.]+\s*(?:kHz|Hz|ms|us|s)\b")
# what is changed on the live system, by a client of the control interface; `plan` fills it
INJECT = """
import json, sys
from reconf_ros.executor.runtime import Runtime
plan = json.loads(sys.argv[1])
rt = Runtime("bench_inject", "", 10.0)
rt.wait(lambda: all(f in rt.nodes() for f in plan["need"]), 30)
for fqn, name, value in plan["set"]:
    rt.set(fqn, name, value)
for fqn in plan["deactivate"]:
    rt.transition(fqn, rt.Transition.TRANSITION_DEACTIVATE, "deactivate")
rt.close()
"""


def system_text(n: int) -> str:
    return RATE.sub("@ 2 Hz", generate("dag", n, seed=1))


def single_topics(text: str, topics: list[str]) -> str:
    """The same model with `topics` declared `single` (each has one publisher as deployed)."""
    for t in topics:
        text = re.sub(rf"^(topic {re.escape(t)}: [^{{\n]*?)(?<! single) \{{", r"\1 single {", text, count=1, flags=re.M)
    return text


def reconf(live: LiveSystem, *args: str) -> tuple[float, subprocess.CompletedProcess[str]]:
    t0 = time.monotonic()
    res = subprocess.run([sys.executable, "-m", "checker", *args], capture_output=True, text=True, env=live.env,
                         cwd=live.dir, timeout=300)
    return time.monotonic() - t0, res


def up(live: LiveSystem, arch: Path, loose: list[str]) -> dict[str, int]:
    """Deploy `arch`, `loose` components each in a process of its own; their PIDs."""
    names = [c.name for c in load([str(arch)]).components]
    live.deploy(str(arch), [n for n in names if n not in loose], generic=True, per_process=10)
    procs = live.deploy(str(arch), loose, generic=True, group=False)
    live.wait_ready(timeout=180)
    return {name: p.pid for name, p in zip(loose, procs)}


def timed(live: LiveSystem, settle: float, model: Path) -> dict[str, Any]:
    snap = live.dir / "snap.json"
    wall_d, res = reconf(live, "discover", "-o", str(live.dir / "found.arch"), "--settle", str(settle),
                         "--save-snapshot", str(snap))
    assert res.returncode == 0, res.stderr
    s = json.loads(snap.read_text())
    wall_r, res = reconf(live, "drift", str(model), "--settle", str(settle), "--output-format", "json")
    doc = json.loads(res.stdout)
    return {"discover": wall_d, "discover_settle": s["settle_seconds"], "nodes": len(s["nodes"]),
            "discover_read": s["seconds"] - s["settle_seconds"], "drift_read": doc["seconds"]["read"],
            "drift": wall_r, "drift_settle": doc["seconds"]["settle"], "false": len(doc["diagnostics"]),
            "false_codes": sorted({d["code"] for d in doc["diagnostics"]})}


def injection(text: str, pids: dict[str, int]) -> tuple[dict[str, Any], list[tuple[str, str]], list[str]]:
    """20 differences: what to set and deactivate, the extra nodes' remaps, and what drift must say."""
    system = load_text(text, "<bench>")
    loose = set(pids)
    comps = [c for c in system.components if c.name not in loose]
    with_fn = [c for c in comps if c.functionalities]
    expected: list[tuple[str, str]] = []
    sets: list[Any] = []
    for c in with_fn[:5]:                                   # 5 modes
        f = c.functionalities[0].name
        sets.append((f"/{c.name}", f"reconf.mode.{f}", "degraded"))
        expected.append(("RC615", c.name))
    roles = {(r.component, r.port) for k in system.connectors for r in k.roles}
    attached = [(c, next(p for p in c.ports if (c.name, p.name) in roles)) for c in with_fn[5:]
                if any((c.name, p.name) in roles for p in c.ports)]
    for i, (c, p) in enumerate(attached[:4]):               # 4 ports: two detached, two moved
        sets.append((f"/{c.name}", f"reconf.port.{p.name}", [] if i < 2 else [f"/bench_elsewhere_{i}"]))
        expected.append(("RC613", f"{c.name}.{p.name}"))
    used = {c.name for c, _ in attached[:4]} | {c.name for c in with_fn[:5]}
    idle = [c for c in comps if c.name not in used]
    deactivate = [f"/{c.name}" for c in idle[:3]]           # 3 lifecycles
    expected += [("RC617", f[1:]) for f in deactivate]
    expected += [("RC611", name) for name in pids]          # 2 missing
    # 2 extra nodes, each publishing Int32 on a single topic of the model: extra, type, single (6)
    one_pub = [k.name for k in system.connectors if k.kind == "topic" and len(k.publishers) == 1]
    extra = one_pub[:2]
    for i, t in enumerate(extra):
        expected += [("RC612", f"bench_extra_{i}"), ("RC614", t), ("RC616", t)]
    plan = {"need": [s[0] for s in sets] + deactivate, "set": sets, "deactivate": deactivate}
    return plan, expected, extra


def detect(live: LiveSystem, text: str, pids: dict[str, int], settle: float) -> dict[str, Any]:
    plan, expected, topics = injection(text, pids)
    model = live.dir / "model.arch"
    model.write_text(single_topics(text, topics))
    _, clean = reconf(live, "drift", str(model), "--settle", str(settle), "--output-format", "json")
    false = json.loads(clean.stdout)["diagnostics"]
    res = subprocess.run([sys.executable, "-c", INJECT, json.dumps(plan)], env=live.env, capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    for pid in pids.values():
        os.kill(pid, signal.SIGTERM)
    for i, t in enumerate(topics):
        live.start([sys.executable, "-m", "reconf_ros.demo.plain", "--ros-args", "-r", f"__node:=bench_extra_{i}",
                    "-r", f"/heard:={t}"], f"extra-{i}.log")
    _, res = reconf(live, "drift", str(model), "--settle", str(settle), "--output-format", "json")
    found = json.loads(res.stdout)["diagnostics"]
    def names(e: tuple[str, str], d: dict[str, Any]) -> bool:
        return d["code"] == e[0] and re.search(rf"(?<!\w){re.escape(e[1])}(?![\w/])", d["message"]) is not None
    hit = [e for e in expected if any(names(e, d) for d in found)]
    return {"injected": len(expected), "found": len(hit), "reported": len(found), "false_clean": len(false),
            "exit": res.returncode, "kinds": Counter(c for c, _ in expected),
            "missed": [e for e in expected if e not in hit], "codes": Counter(d["code"] for d in found)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="10,50,100")
    ap.add_argument("--settle", type=float, default=15.0, help="--settle of discover and drift")
    ap.add_argument("--no-bag", action="store_true", help="leave out the check of 1/4, 1/2 and 1 GiB recordings "
                                                         "(bench.bench_bag) that ends the run")
    args = ap.parse_args(argv)
    sizes = [int(x) for x in args.sizes.split(",")]
    print("| components | nodes read | discover s | settling | reading | rest | drift s | settling | reading | rest "
          "| drift reported on the unchanged system |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    detection = None
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            with LiveSystem(Path(tmp) / f"n{n}") as live:
                live.watch()
                text = system_text(n)
                arch = live.dir / "system.arch"
                arch.write_text(text)
                names = [c.name for c in load([str(arch)]).components]
                pids = up(live, arch, names[-2:])
                r = timed(live, args.settle, arch)
                cells = [f"{r[cmd]:.2f} | {r[cmd + '_settle']:.2f} | {r[cmd + '_read']:.2f} | "
                         f"{r[cmd] - r[cmd + '_settle'] - r[cmd + '_read']:.2f}" for cmd in ("discover", "drift")]
                print(f"| {n} | {r['nodes']} | {cells[0]} | {cells[1]} | {r['false']} {' '.join(r['false_codes'])} |",
                      flush=True)
                if n == max(sizes):
                    detection = detect(live, text, pids, args.settle)
    if detection:
        d = detection
        print(f"\n| drift on {max(sizes)} components | injected | found | reported | on the unchanged system | exit |")
        print("|---|---|---|---|---|---|")
        kinds = ", ".join(f"{k}×{v}" for k, v in sorted(d["kinds"].items()))
        print(f"| {kinds} | {d['injected']} | {d['found']} | {d['reported']} | {d['false_clean']} | {d['exit']} |")
        if d["missed"]:
            print(f"missed: {d['missed']}; reported codes: {dict(d['codes'])}")
    print("(wall time of the command, Python start-up included; settling: waiting for discovery; reading: every "
          "node's endpoints, lifecycle, model, modes and attachments; rest: Python start-up, rclpy.init, parsing, "
          "comparing or writing)")
    if not args.no_bag:
        from bench import bench_bag
        print("\n`reconf check --bag` on recordings of growing length (bench.bench_bag):", flush=True)
        return bench_bag.main([])
    return 0


if __name__ == "__main__":
    sys.exit(main())
