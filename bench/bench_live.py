"""Plans carried out on live ROS 2 systems, measured on the wire (docs/runtime.md).

For each scenario and strategy, N runs (default 20) of: deploy the example with its real nodes,
plan the change (`--no-alloy`: the Python engine verifies it), run the plan script, read what
the monitors saw. Prints, per scenario, the median / p95 / max of: plan wall time (the script,
from start to exit), per-step latency, the largest input gap of a normal-mode functionality
against its assumed period, messages lost (sequence gaps, and the head a new publisher lost
before its subscribers heard it), steps and seconds a functionality spent degraded; and runs
with a violation or a failure. Then a 50-component live system (model-driven nodes in five
processes): the wall time of replacing its hub, by the plan script alone and through a manager.

    python -m bench.bench_live [--runs 20] [--only chatter] [--big-runs 5]
    python -m bench.bench_live --only unmodified --runs 5 --big-runs 0 --save runs.jsonl   # in chunks…
    python -m bench.bench_live --table runs.jsonl                                           # …one table

`--save` appends each run's figures to a file, so that rows can be measured in several short
runs (a live machine shared by others is held for minutes, not an hour); `--table` prints the
rows of every run saved there.
"""
from __future__ import annotations

import argparse
import json
import re
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from checker.reports.timeline import timeline
from reconf_ros.executor.plan_states import PlanStates
from reconf_ros.tools.livetest import LiveSystem

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"

# name, architecture, plan arguments
SCENARIOS = [
    ("chatter replace talker", "chatter.arch", ["replace", "talker"]),
    # /chatter made `single`: the listener must degrade while one talker leaves and the other comes
    ("chatter replace talker on a single topic", "chatter.arch single", ["replace", "talker"]),
    ("robot remove obstacle_detector", "robot.arch", ["remove", "obstacle_detector"]),
    ("redundant replace lidar_rear", "redundant.arch", ["replace", "lidar_rear"]),
    ("chain5 replace stage0", "chain5.arch", ["replace", "stage0"]),
    ("chatter migrate", "chatter.arch", ["migrate", str(EX / "chatter.arch"), str(EX / "chatter_migrated.arch")]),
    # nodes reconf does not build, driven through adapters (docs/adapter.md)
    ("unmodified replace plain talker by lifecycle talker", "unmodified.arch", ["replace", "talker"]),
    ("unmodified remove plain talker", "unmodified.arch", ["remove", "talker"]),
]


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def arch_file(arch: str, work: Path) -> str:
    """The architecture a scenario names: an example, or (`NAME single`) the example with its
    topics made `single`, written into `work`."""
    name, _, variant = arch.partition(" ")
    if not variant:
        return str(EX / name)
    text = re.sub(r"^(topic \S+: \S+ @ [^{]+?) \{", r"\1 single {", (EX / name).read_text(), flags=re.M)
    work.mkdir(parents=True, exist_ok=True)
    (work / name).write_text(text)
    return str(work / name)


def measure(arch: str, args: list[str], strategy: str, work: Path, manager: bool = False) -> dict[str, Any]:
    path = arch_file(arch, work / "arch")
    with LiveSystem(work) as live:
        live.watch()
        sock = live.manager() if manager else ""
        live.deploy(path)
        live.wait_ready(timeout=30)
        plan_args = list(args) + ([] if args[0] == "migrate" else ["-f", path]) + ["--strategy", strategy]
        script = live.plan_script(plan_args)
        t0 = time.monotonic()
        res = live.run_plan(script, *(["--manager", sock] if sock else []))
        wall = time.monotonic() - t0
        report = live.report()
        final = (report.get("observed") or {}).get("components", [])
        statuses = live.settle_status(final)
    doc = report.get("plan_document", {})
    states = [st.to_doc() for st in PlanStates(doc["plan"])] if doc.get("plan") else []
    created = {s["component"] for s in doc.get("plan", {}).get("steps", []) if s["action"] == "create"}
    renames = doc.get("plan", {}).get("renames", {})
    created = {renames.get(c, c) for c in created}
    lost, gap_ratio = 0, 0.0
    for name, st in statuses.items():
        v = st["values"]
        for k, x in v.items():
            if ".from." in k:
                node = k.split(".from.", 1)[1]
                _, seq_lost, head = (int(y) for y in x.split("/"))
                lost += seq_lost + (head if node in created else 0)
            if k.endswith(".max_gap_s"):
                port = k.split(".")[1]
                period = assumed_period(doc, name.lstrip("/"), port)
                if period:
                    gap_ratio = max(gap_ratio, float(x) / period)
    timings = report.get("timings", [])
    # degraded: steps and seconds each functionality that served before the plan spent degraded
    # (normal at the end), as the plan's estimate counts them (checker.planning.durations); the
    # seconds as `reconf timeline` measures them (the steps of a batch overlap)
    end = states[-1] if states else {"degraded": []}
    residual = {tuple(d) for d in end["degraded"]}
    served = set(states[0]["components"]) if states else set()
    drawn = timeline(report) if timings else None
    steps_deg, secs_deg = 0, 0.0
    for f in {tuple(d) for s in states[1:] for d in s["degraded"] if d[0] in served} - residual:
        n = [i for i, s in enumerate(states[1:], 1) if list(f) in s["degraded"] and f[0] in s["components"]]
        steps_deg = max(steps_deg, len(n))
        secs_deg = max(secs_deg, drawn.degraded_seconds(".".join(f)) if drawn else 0.0)
    return {"ok": res.returncode == 0, "violations": len(live.violations(statuses)), "wall": wall,
            "steps": [t["seconds"] for t in timings], "timings": timings, "gap_ratio": gap_ratio, "lost": lost,
            "creates": [t["seconds"] for t in timings if t.get("action") == "create"],
            "steps_degraded": steps_deg, "seconds_degraded": secs_deg, "stderr": res.stderr[-400:],
            "seconds_planned": max((f["seconds"] for f in (doc.get("plan", {}).get("seconds") or {}).get(
                "functionalities", []) if (f["component"], f["functionality"]) not in residual), default=0.0),
            "seen": live.watched_violations()[-5:]}


def assumed_period(doc: dict[str, Any], comp: str, port: str) -> float:
    for c in doc.get("model", {}).get("components", []):
        if c["name"] == comp:
            for p in c["ports"]:
                if p["name"] == port and p.get("assumption") and p["assumption"].get("hz"):
                    from fractions import Fraction
                    return 1 / float(Fraction(p["assumption"]["hz"]))
    return 0.0


def big_system(path: Path, n: int = 50, lean: bool = True) -> None:
    """A hub at 10 Hz, relays reading it, sinks reading the relays: n components in all, lean
    nodes (docs/runtime.md#cost) unless `lean` is false."""
    relays = (n - 1) // 2
    sinks = n - 1 - relays
    lines = ["system big", "message String = std_msgs/msg/String", ""]
    run = f'  run "reconf-node{" --lean" if lean else ""} --arch {path} {{}}"'
    for name, extra in (("hub", ""), ("hub_v2", " replaces hub")):
        lines += [f"component {name}{extra} {{", run.format(name), "  output out: String",
                  "  functionality pub (out) { normal { out: String @ 10 Hz } degraded { out: nothing } }", "}"]
    for i in range(relays):
        lines += [f"component relay{i} {{", run.format(f"relay{i}"), "  input in: String @ 10 Hz", "  output out: String",
                  "  functionality relay (in, out) { normal { assume String @ 10 Hz  out: String @ 5 Hz }"
                  " degraded { out: nothing } }", "}"]
    for i in range(sinks):
        lines += [f"component sink{i} {{", run.format(f"sink{i}"), "  input in: String @ 5 Hz",
                  "  functionality use (in) { normal { assume String @ 5 Hz } degraded { } }", "}"]
    lines.append("topic /hub: String @ 10 Hz { hub.out -> " + ", ".join(f"relay{i}.in" for i in range(relays)) + " }")
    for i in range(relays):
        subs = ", ".join(f"sink{j}.in" for j in range(sinks) if j % relays == i)
        lines.append(f"topic /relay{i}: String @ 5 Hz {{ relay{i}.out -> {subs} }}")
    path.write_text("\n".join(lines) + "\n")


def measure_big(work: Path, n: int, manager: bool, lean: bool) -> dict[str, Any]:
    """Replace the hub of an n-component system: the plan script on its own, or through a
    manager started with the system (docs/executor.md#manager). Violations are counted over
    the plan's run only (the monitors' counters before and after)."""
    work.mkdir(parents=True, exist_ok=True)
    arch = work / "big.arch"
    big_system(arch, n, lean)
    with LiveSystem(work) as live:
        live.watch()
        sock = live.manager() if manager else ""
        live.deploy(str(arch), per_process=10)
        live.wait_ready(timeout=90)
        script = live.plan_script(["replace", "hub", "-f", str(arch)])
        before = counts(live.settle_status(live.deployed))
        t0 = time.monotonic()
        res = live.run_plan(script, *(["--manager", sock] if sock else []))
        wall = time.monotonic() - t0
        after = counts(live.settle_status(["hub_v2"]))
        bad = {c: k - before.get(c, 0) for c, k in after.items() if k > before.get(c, 0)}
        return {"ok": res.returncode == 0, "wall": wall, "violations": len(bad),
                "timings": live.report().get("timings", []), "stderr": res.stderr[-600:],
                "seen": live.watched_violations()[-5:] if bad else []}


def counts(statuses: dict[str, Any]) -> dict[str, int]:
    return {n: int(s["values"].get("violations", "0")) for n, s in statuses.items()}


def row(name: str, runs: list[dict[str, Any]]) -> str:
    def stat(key: str, fmt: str = "{:.2f}") -> str:
        xs = [r[key] for r in runs]
        return "/".join(fmt.format(x) for x in (statistics.median(xs), pct(xs, 0.95), max(xs)))
    def spread(xs: list[float]) -> str:
        return "/".join(f"{x:.3f}" for x in (statistics.median(xs), pct(xs, 0.95), max(xs))) if xs else "-"
    step = spread([s for r in runs for s in r["steps"]])
    creates = spread([s for r in runs for s in r.get("creates", [])])
    bad = sum(1 for r in runs if not r["ok"] or r["violations"])
    return (f"| {name} | {len(runs)} | {bad} | {stat('wall')} | {step} | {creates} | {stat('gap_ratio')} | "
            f"{stat('lost', '{:.0f}')} | {stat('steps_degraded', '{:.0f}')} | {stat('seconds_degraded')} | "
            f"{stat('seconds_planned')} |")


HEADER = ("| scenario | runs | failed or violated | plan wall s | step s | create s | largest gap / period | "
          "lost | steps degraded | s degraded | s degraded, planned |\n|---|---|---|---|---|---|---|---|---|---|---|")


def saved_table(path: Path) -> None:
    """The rows of the runs `--save` wrote to `path`, one per scenario and strategy, in order."""
    rows: dict[str, list[dict[str, Any]]] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        run = json.loads(line)
        rows.setdefault(run.pop("row"), []).append(run)
    if not rows:
        raise SystemExit(f"{path}: no run saved")
    print(HEADER)
    for name, runs in rows.items():
        print(row(name, runs))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--only", default="", help="scenarios whose name contains this")
    ap.add_argument("--strategies", default="default,paper")
    ap.add_argument("--how", default="script",
                    help="script (the plan script on its own), manager (through a manager started with the "
                         "system, which forks the new nodes from its launcher), or both, comma-separated")
    ap.add_argument("--big-runs", type=int, default=5)
    ap.add_argument("--big-n", type=int, default=50)
    ap.add_argument("--save", default="", help="append each scenario run's figures to this file (JSON lines)")
    ap.add_argument("--table", default="", help="print the rows of the runs saved in this file, and nothing else")
    ap.add_argument("--big-how", default="script,manager,manager-full",
                    help="big-system rows: script (the plan script on its own), manager (through a running "
                         "manager); -full: nodes with every standard service, not lean")
    args = ap.parse_args()
    if args.table:
        saved_table(Path(args.table))
        return
    if args.runs > 0 and not any(args.only in name for name, _, _ in SCENARIOS):
        raise SystemExit(f"--only {args.only!r} matches no scenario: " + "; ".join(n for n, _, _ in SCENARIOS))
    print(HEADER)
    with tempfile.TemporaryDirectory() as tmp:
        for k, (name, arch, plan_args) in enumerate(SCENARIOS):
            if args.only not in name or args.runs < 1:
                continue
            for strategy, how in [(s, h) for s in args.strategies.split(",") for h in args.how.split(",")]:
                runs, label = [], f"{name} ({strategy}{', through a manager' if how == 'manager' else ''})"
                for i in range(args.runs):
                    r = measure(arch, plan_args, strategy, Path(tmp) / f"row{k}-{strategy}-{how}-{i}", how == "manager")
                    if args.save:
                        with open(args.save, "a", encoding="utf-8") as fh:
                            fh.write(json.dumps({"row": label, **r}) + "\n")
                    if not r["ok"] or r["violations"]:
                        print(f"  (run {i}: {'failed' if not r['ok'] else 'violation'}: {r['stderr']})", flush=True)
                        for line in r["seen"]:
                            print(f"  (run {i}: {line})", flush=True)
                    runs.append(r)
                print(row(label, runs), flush=True)
        if args.big_runs:
            print(f"\n| {args.big_n}-component live system, replace the hub (default strategy) | runs | failed | "
                  "runs with a violation during the plan | plan wall s (median/p95/max) | create s | attach s |")
            print("|---|---|---|---|---|---|---|")
            for key in args.big_how.split(","):
                manager, lean = key.startswith("manager"), not key.endswith("-full")
                how = ("through a running manager" if manager else "plan script on its own") + \
                    ("" if lean else ", nodes not lean")
                runs = []
                for i in range(args.big_runs):
                    r = measure_big(Path(tmp) / f"big-{key}-{i}", args.big_n, manager, lean)
                    if not r["ok"]:
                        print(f"  (big run {i}: {r['stderr']})", flush=True)
                    for line in r["seen"]:
                        print(f"  (big run {i}: {line})", flush=True)
                    runs.append(r)
                walls = [r["wall"] for r in runs]
                step = {a: [t["seconds"] for r in runs for t in r["timings"] if t.get("action") == a]
                        for a in ("create", "attach")}
                print(f"| {how} | {len(runs)} | {sum(not r['ok'] for r in runs)} | "
                      f"{sum(1 for r in runs if r['violations'])} | "
                      f"{statistics.median(walls):.2f}/{pct(walls, 0.95):.2f}/{max(walls):.2f} | "
                      + " | ".join(f"{statistics.median(v):.2f}" if v else "-" for v in step.values()) + " |",
                      flush=True)
    print("(median/p95/max; gap = largest wait of a normal functionality's input over its assumed period; lost = "
          "sequence gaps plus what a created publisher lost before its subscribers heard it)")


if __name__ == "__main__":
    main()
