"""Faults of hosts and links on a lab of hosts (reconf_ros.tools.netlab: a network namespace per
host, docs/hosts.md): the FTMs of paper 000 under a client's load, and a plan across two hosts
on a lossy link.

For PBR and LFR, N runs (default 20) of: expand examples/ftm/client_server_pbr_tr.arch with that
FTM, deploy it on the hosts the architecture names (client_site, master, slave), the demo
client at --hz requests/s; once the backup's detector has armed and served for its jitter
window, either crash the master host (every process of it killed) or cut it off (its link down)
for --cut seconds and heal it. Per row, median/p95/max of the take-over time (from the fault to
the first reply after the client's longest wait) and of that wait, the requests lost, answered
twice and answered wrong over the client's whole history (reconf_ros.demo.history: `wrong`
counts every anomaly but loss), how many runs had none, and, for partitions, how many runs the
old primary published a reply after healing and in how many it had fenced itself while cut off.

Then, the chatter replace across two hosts (examples/chatter_hosts.arch: the talker on the robot,
the listener on the station, where the plan runs; the robot's agent starts talker_v2 there), without and with --loss % of the robot's packets dropped each way while the
plan runs: the plan's wall time, the listener's largest wait for a message over its assumed
period, messages lost, the run's outcome (done; violated: done, but a monitor saw a normal mode's
assumption violated; or failed), and whether the configuration its report says it observed
agrees with bench.probe's own reading of the graph (bench_faults' comparison).

    python -m bench.bench_hosts [--runs 20] [--hz 50] [--only 'PBR crash,LFR partition,chatter'] [--results FILE]
                                [--keep DIR]

With --results, each run is appended to FILE (JSON lines) and the table is printed from every
run FILE holds for the rows asked: run the 20 runs in chunks (`--runs 5` four times).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench.bench_faults import as_configuration, differences, from_doc
from reconf_ros.demo.ftm import read_log, wait_replies
from reconf_ros.demo.history import ANOMALIES, check_history
from reconf_ros.nodes.ftm.detect import JITTER_WINDOW
from reconf_ros.tools.livetest import LiveSystem
from reconf_ros.tools.netlab import hosts_of

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "ftm" / "client_server_pbr_tr.arch"
ROWS = [("PBR", "crash"), ("LFR", "crash"), ("PBR", "partition"), ("LFR", "partition"),
        ("chatter replace", "none"), ("chatter replace", "loss")]
CHATTER = ROOT / "examples" / "chatter_hosts.arch"
PRIMARY = "master"
OLD_PROTOCOL = "/server__r0_dup_protocol"


def takeover(replies: list[float], fault: float) -> tuple[float, float]:
    """From the fault to the first reply after the client's longest wait for one (the outage),
    and that wait."""
    gaps = [(b - a, b) for a, b in zip(replies, replies[1:]) if b > fault and a > fault - 1.0]
    if not gaps:
        return float("nan"), float("nan")
    wait, end = max(gaps)
    return end - fault, wait


def after_heal(live: LiveSystem, healed: float, watch_s: float) -> dict[str, Any]:
    """Once the old primary's nodes are heard again: whether they were fenced while cut off,
    and how many replies its protocol published in the next `watch_s` seconds."""
    heard = live.wait(lambda st: st.get(OLD_PROTOCOL, {}).get("seen", 0) > healed
                      and st.get("/server__r0_cd", {}).get("seen", 0) > healed, 15)
    first = live.statuses()
    time.sleep(watch_s)
    later = live.settle_status([OLD_PROTOCOL.lstrip("/")])

    def published(st: dict[str, Any]) -> int:
        return int(st.get(OLD_PROTOCOL, {}).get("values", {}).get("out.reply.published", "0"))
    fenced_at = first.get("/server__r0_cd", {}).get("values", {}).get("app.fenced_at", "")
    return {"heard": heard, "answers_after_heal": published(later) - published(first),
            "fenced_while_cut": bool(fenced_at) and float(fenced_at) < healed,
            "old_lifecycle": later.get(OLD_PROTOCOL, {}).get("values", {}).get("lifecycle", "?")}


def measure(ftm: str, fault: str, hz: float, work: Path, cut: float) -> dict[str, Any]:
    """One run: the FTM served on the lab, the fault struck at the primary's host, the history judged."""
    with LiveSystem(work, hosts=hosts_of([str(EXAMPLE)]), home="client_site") as live:
        live.watch()
        try:
            _, log = live.serve_ftm(str(EXAMPLE), ftm, hz)
        except TimeoutError as e:
            return {"ok": False, "why": str(e)[:300]}
        if not wait_replies(log, 25, timeout=60) or not live.wait_detectors_armed(timeout=30):
            return {"ok": False, "why": "no replies, or the crash detector never armed"}
        time.sleep(JITTER_WINDOW)       # in service: the start-up's late beats have left the detector's window
        limit = float(live.statuses().get("/server__r1_cd", {}).get("values", {}).get("app.silence_limit_s", "nan"))
        t0, extra = time.time(), {}
        if fault == "crash":
            live.crash(PRIMARY)
        else:
            live.partition(PRIMARY)
        served = wait_replies(log, int(2 * hz), timeout=20, after=t0 + 0.05)
        if fault == "partition":
            time.sleep(max(0.0, t0 + cut - time.time()))
            live.heal(PRIMARY)
            extra = after_heal(live, time.time(), watch_s=3.0)
        time.sleep(2.0)
        read_at = time.time()
        entries = read_log(str(log))
    verdict = check_history(entries, until=read_at - 1.5)
    replies = sorted(r[0]["t"] for r in entries["replies"].values())
    took, wait = takeover(replies, t0)
    return {"ok": served, "why": "" if served else "no replies after the fault", "takeover": took, "wait": wait,
            "lost": len(verdict["lost"]), "dup": len(verdict["duplicated"]),
            "wrong": sum(len(verdict[k]) for k in ANOMALIES if k not in ("lost", "duplicated")),
            "limit": limit, "completed": verdict["completed"], **extra}


def measure_plan(loss: float, work: Path) -> dict[str, Any]:
    """One run of the chatter replace across two hosts, the robot's link losing `loss` % meanwhile."""
    with LiveSystem(work, hosts=["robot", "station"], home="station") as live:
        live.watch()
        hosts_file = live.agents()
        live.deploy_by_host(str(CHATTER))
        try:
            live.wait_ready(["talker", "listener"], timeout=60)
        except TimeoutError as e:
            return {"ok": False, "why": str(e)[:300]}
        script = live.plan_script(["replace", "talker", "-f", str(CHATTER), "--with", "talker_v2"])
        if loss:
            live.loss("robot", loss)
        t0 = time.monotonic()
        res = live.run_plan(script, "--hosts", str(hosts_file), timeout=300)
        wall = time.monotonic() - t0
        live.heal("robot")
        report = live.report()
        true, why_not = judge_report(live, report)
        started = report.get("started", {}).get("talker_v2", {})
        on_robot = started.get("host") == "robot" and int(started.get("pid", 0)) in live.lab.pids("robot") \
            if live.lab is not None else False
        values = live.settle_status(["listener"]).get("/listener", {}).get("values", {})
    lost = sum(int(x.split("/")[1]) for k, x in values.items() if k.startswith("in.in.from."))
    outcome = report.get("outcome", "no report")
    return {"ok": True, "outcome": outcome, "done": res.returncode == 0 and outcome == "done", "wall": wall,
            "gap": float(values.get("in.in.max_gap_s", "nan")) / 0.1, "lost": lost, "on_robot": on_robot,
            "why": (report.get("reason") or "")[:200], "violated": outcome == "violated",
            "true": true, "why_not_true": why_not}


def judge_report(live: LiveSystem, report: dict[str, Any]) -> tuple[bool, str]:
    """The configuration the run's report says it observed at its end, against bench.probe's own
    reading of the live graph from the station (the link healed: what the nodes hold is kept)."""
    if "observed" not in report:
        return False, "no report"
    out = live.dir / "probe.json"
    res = subprocess.run(live.on_host(None, [sys.executable, "-m", "bench.probe", "--out", str(out)]), env=live.env,
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    if res.returncode != 0:
        return False, f"the probe failed: {res.stderr[-300:]}"
    doc = report["plan_document"]
    comps = {c["name"] for c in doc["model"]["components"]}
    seen, _, _ = as_configuration(json.loads(out.read_text()), comps, report.get("placed") or {},
                                  doc["plan"].get("renames") or {})
    diffs = differences(from_doc(report["observed"]), seen, set(report.get("unread") or []))
    return not diffs, "; ".join(diffs)


def plan_table(results: list[dict[str, Any]], loss: float) -> None:
    if not any(r.get("row", [""])[0] == "chatter replace" for r in results):
        return
    print("| plan across two hosts | robot's link | runs | done | violated | failed | report true | wall s "
          "| largest gap / period | messages lost | talker_v2 on the robot |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for fault in ("none", "loss"):
        runs = [r for r in results if r.get("row") == ["chatter replace", fault] and r["ok"]]
        if not runs:
            continue
        done = [r for r in runs if r["done"]]
        violated = [r for r in runs if r["violated"]]
        print(f"| chatter replace | {'lossless' if fault == 'none' else f'{loss:g} % lost each way'} | {len(runs)} | "
              f"{len(done)} | {len(violated)} | {len(runs) - len(done) - len(violated)} | "
              f"{sum(1 for r in runs if r.get('true'))} of {len(runs)} | {three([r['wall'] for r in runs])} | "
              f"{three([r['gap'] for r in runs])} | {three([r['lost'] for r in runs], '{:.0f}')} | "
              f"{sum(1 for r in runs if r['on_robot'])} of {len(runs)} |", flush=True)
        for r in runs:
            if not r["done"]:
                print(f"  ({r['outcome']}: {r['why'] or 'a monitor saw an assumption violated'})")
            if not r.get("true"):
                print(f"  (the report disagrees with the probe: {r.get('why_not_true', '')})")


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def three(xs: list[float], fmt: str = "{:.2f}") -> str:
    return "/".join(fmt.format(x) for x in (statistics.median(xs), pct(xs, 0.95), max(xs))) if xs else "-"


def row_line(ftm: str, fault: str, runs: list[dict[str, Any]]) -> str:
    ok = [r for r in runs if r["ok"]]
    clean = sum(1 for r in ok if r["lost"] == r["dup"] == r["wrong"] == 0)
    heal = "-"
    if fault == "partition":
        heal = (f"{sum(1 for r in ok if r.get('answers_after_heal', 0) > 0)} / "
                f"{sum(1 for r in ok if r.get('fenced_while_cut'))}")
    return (f"| {ftm} | {fault} | {len(runs)} | {len(runs) - len(ok)} | {three([r['takeover'] for r in ok])} | "
            f"{three([r['wait'] for r in ok])} | {three([r['lost'] for r in ok], '{:.0f}')} | "
            f"{three([r['dup'] for r in ok], '{:.0f}')} | {three([r['wrong'] for r in ok], '{:.0f}')} | "
            f"{clean} of {len(ok)} | {heal} |")


def table(results: list[dict[str, Any]], rows: list[tuple[str, str]]) -> None:
    rows = [r for r in rows if r[0] != "chatter replace"]
    if not rows:
        return
    print("| FTM | fault of the primary's host | runs | failed | take-over s | longest wait s | lost | answered twice "
          "| wrong | runs with 0/0/0 | old primary answered after healing / fenced while cut off |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for ftm, fault in rows:
        runs = [r for r in results if r.get("row") == [ftm, fault]]
        if runs:
            print(row_line(ftm, fault, runs), flush=True)
            limits = [r["limit"] for r in runs if r.get("ok") and r.get("limit") == r.get("limit")]
            if limits:
                print(f"  (the backup's silence limit at the fault: {three(limits, '{:.3f}')} s)")
            for r in runs:
                if not r["ok"]:
                    print(f"  (failed: {r['why']})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--hz", type=float, default=50)
    ap.add_argument("--cut", type=float, default=3.0, help="seconds a partition lasts")
    ap.add_argument("--loss", type=float, default=10.0, help="%% of the robot's packets lost each way in the loss row")
    ap.add_argument("--only", default="", help="rows whose 'FTM fault' contains one of these (comma-separated)")
    ap.add_argument("--results", default="", help="append each run here (JSON lines); the table counts them all")
    ap.add_argument("--keep", default="", help="keep each run's directory (its nodes' logs, the client's log) under "
                    "this one instead of removing it")
    args = ap.parse_args()
    rows = [r for r in ROWS if not args.only or any(o.strip() in f"{r[0]} {r[1]}" for o in args.only.split(","))]
    if not rows:
        raise SystemExit(f"--only {args.only!r} matches no row (rows: {', '.join(f'{a} {b}' for a, b in ROWS)})")
    print(f"client at {args.hz:g} requests/s; partitions of {args.cut:g} s; median/p95/max over runs; "
          f"load average at the start {os.getloadavg()[0]:.2f}", flush=True)
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as scratch:
        tmp = args.keep or scratch
        for ftm, fault in rows:
            for i in range(args.runs):
                work = Path(tmp) / f"{ftm.replace(' ', '_')}-{fault}-{i}"
                r = measure_plan(args.loss if fault == "loss" else 0.0, work) if ftm == "chatter replace" else \
                    measure(ftm, fault, args.hz, work, args.cut)
                r.update(row=[ftm, fault], load=os.getloadavg()[0], at=time.time())
                results.append(r)
                if args.results:
                    with open(args.results, "a") as fh:
                        fh.write(json.dumps(r) + "\n")
    if args.results:
        results = [json.loads(line) for line in Path(args.results).read_text().splitlines() if line.strip()]
    table(results, rows)
    plan_table(results, args.loss)
    loads = [r["load"] for r in results if r.get("row") in [list(x) for x in rows]]
    print(f"(load average, 1 min, after each run: {three(loads)} median/p95/max)")


if __name__ == "__main__":
    main()
