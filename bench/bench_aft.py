"""Adaptive fault tolerance on live ROS 2: the FTM nodes of reconf_ros.nodes.ftm under a client's load.

For each FTM of the table, N runs (default 10) of: expand examples/ftm/client_server_pbr_tr.arch
with that FTM, deploy it one process per host, run the demo client at --hz requests/s, then
(steady) measure, or (crash) kill -9 the primary's host process once it has served for the
detector's jitter window after arming (its start-up's late beats forgotten; the backup's silence
limit at that moment is printed), or (transient) make one computation of the primary's
application wrong. Prints per row the median / p95 / max of: reply
latency, requests lost, duplicated and answered wrongly, and for faults the longest time the
client went without a reply (from the fault) and the affected request's latency. A transition
row (`PBR -> LFR`) carries out the verified plan of `reconf plan transition` while the client
sends; its latencies are those of the replies during the plan, and it gives the plan's wall time
and the client's seconds degraded (by the executor's step times) next to the plan's estimate.

    python -m bench.bench_aft [--runs 10] [--hz 50] [--only PBR]
"""
from __future__ import annotations

import argparse
import os
import re
import shlex
import signal
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any, Optional

from checker.reports.timeline import timeline
from reconf_ros.demo.ftm import judge_log, read_log, wait_replies
from reconf_ros.nodes.ftm.detect import JITTER_WINDOW
from reconf_ros.tools.livetest import LiveSystem

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "ftm" / "client_server_pbr_tr.arch"
CLIENT_USE = ("client", "use")     # the functionality a transition degrades that the user sees

# name, FTM (None: the bare server), fault
ROWS: list[tuple[str, Optional[str], str]] = [
    ("bare server", None, "none"),
    ("PBR", "PBR", "none"), ("LFR", "LFR", "none"), ("TR", "TR", "none"), ("AD", "AD", "none"),
    ("SEC", "SEC", "none"), ("PBR(TR)", "PBR(TR)", "none"), ("SEC(PBR(TR))", "SEC(PBR(TR))", "none"),
    ("PBR, primary host killed", "PBR", "crash"), ("LFR, primary host killed", "LFR", "crash"),
    ("TR, one computation wrong", "TR", "transient"), ("AD, one computation wrong", "AD", "transient"),
] + [(f"{a} -> {b}", a, f"to {b}") for a, b in (("PBR", "LFR"), ("LFR", "PBR"), ("PBR", "PBR(TR)"),
                                                 ("PBR(TR)", "PBR"), ("PBR(TR)", "SEC(PBR(TR))"),
                                                 ("SEC(PBR(TR))", "PBR(TR)"))]
# "to X": the verified plan of `reconf plan transition server X` carried out while the client sends


def measure(ftm: Optional[str], fault: str, hz: float, work: Path, seconds: float,
            plan_args: tuple[str, ...] = ()) -> dict[str, Any]:
    with LiveSystem(work) as live:
        arch, plan = str(EXAMPLE), None
        try:
            if fault.startswith("to "):
                assert ftm is not None
                arch = live.with_ftm(str(EXAMPLE), ftm, towards=fault[3:])
                plan = live.plan_script(["transition", "server", fault[3:], "-f", arch])
                procs, log = live.serve_ftm(arch, "", hz)
            else:
                procs, log = live.serve_ftm(arch, ftm, hz)
        except TimeoutError as e:
            return {"ok": False, "why": str(e)[:300]}
        if not wait_replies(log, 25, timeout=60):
            return {"ok": False, "why": "no replies"}
        inject = live.injector("/server/ftm/r0/srv/request") if fault == "transient" else None
        if inject is not None:
            inject.wait_ready()
        if fault != "none" and plan is None and not live.wait_detectors_armed(timeout=30):
            return {"ok": False, "why": "the crash detector never armed"}
        limit = None
        if fault == "crash":    # a crash in service: the start-up's late beats have left the detector's window
            time.sleep(JITTER_WINDOW)
            limit = float(live.statuses().get("/server__r1_cd", {}).get("values", {}).get("app.silence_limit_s", "nan"))
        t0, wall = time.time(), 0.0
        if plan is not None:
            res = live.run_plan(plan, *plan_args, timeout=300)
            wall = time.time() - t0
            (work / "plan.out").write_text(f"{t0:.3f} started\n" + res.stdout + res.stderr)   # where its time went
            named = re.findall(r"but the monitor of (\S+) saw", res.stdout + res.stderr)
            report = live.report()
            degraded = client_degraded(report)
            if report.get("outcome") not in ("done", "violated"):
                return {"ok": False, "why": (res.stdout + res.stderr)[-600:]}
            drained = time.time() + 60      # the queue the suspension built, drained: the client caught up
            while time.time() < drained and judge_log(read_log(str(log)), until=time.time() - 1.5)["lost"]:
                time.sleep(0.5)
        elif fault == "crash":
            os.killpg(procs["master"], signal.SIGKILL)
        elif inject is not None:
            inject.send({"tag": "fault", "ops": [{"op": "flip", "n": 1}]})
        wait_replies(log, int(seconds * hz), timeout=seconds * 3, after=t0)
        time.sleep(1.0)
        read_at = time.time()
        entries = read_log(str(log))
    verdict = judge_log(entries, until=read_at - 1.5)   # not after the system's stop: that takes seconds
    replies = sorted(r[0]["t"] for r in entries["replies"].values())
    after = [t for t in replies if t > t0 - 1.0]
    silence = max((b - a for a, b in zip(after, after[1:]) if b > t0), default=0.0) if fault != "none" else 0.0
    lat = [r[0]["latency_s"] for r in entries["replies"].values() if r[0]["t"] > t0 - 1.0]
    if plan is not None:    # the transition's own window: from the plan's start to its end
        lat = [r[0]["latency_s"] for r in entries["replies"].values() if t0 <= r[0]["t"] <= t0 + wall + 1.0]
    # the mechanism answers in order: a request with no reply while a later one has one is lost;
    # the unanswered ones after the last reply are a queue still draining when the run was judged
    last = max(entries["replies"], default=0)
    lost = [i for i in verdict["lost"] if i < last]
    return {"ok": True, "lost": len(lost), "behind": len(verdict["lost"]) - len(lost),
            "dup": len(verdict["duplicated"]), "wrong": len(verdict["wrong"]),
            "lat": lat, "silence": silence, "worst": max(lat, default=0.0), "n": len(lat), "wall": wall,
            "named": named if plan is not None else [], "limit": limit,
            "degraded": degraded if plan is not None else None}


def client_degraded(report: dict[str, Any]) -> tuple[float, float]:
    """The client's seconds degraded in a run, as `reconf timeline` draws them from the executor's
    step times, and as the plan estimated them (docs/soundness.md#seconds-on-the-wire)."""
    planned = (report.get("plan_document", {}).get("plan", {}).get("seconds") or {}).get("functionalities", [])
    estimate = next((f["seconds"] for f in planned if (f["component"], f["functionality"]) == CLIENT_USE), 0.0)
    return (timeline(report).degraded_seconds(".".join(CLIENT_USE)) if report.get("timings") else 0.0), estimate


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def three(xs: list[float], fmt: str = "{:.1f}", scale: float = 1.0) -> str:
    if not xs:
        return "-"
    return "/".join(fmt.format(x * scale) for x in (statistics.median(xs), pct(xs, 0.95), max(xs)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--hz", type=float, default=50)
    ap.add_argument("--seconds", type=float, default=4.0, help="measured after the fault (or the start)")
    ap.add_argument("--only", default="", help="rows whose name contains one of these (comma-separated; "
                    "=NAME: the row of that name only, e.g. =PBR)")
    ap.add_argument("--keep", default="", help="keep each run's logs and reports under this directory")
    ap.add_argument("--plan-args", default="", metavar="ARGS",
                    help="more options for a transition's plan script, e.g. \"--no-hold\" (docs/executor.md#held)")
    args = ap.parse_args()
    print(f"client at {args.hz:g} requests/s; median/p95/max over runs (latency: over every reply of every run)")
    print("| FTM | fault | runs | failed | lost | duplicated | wrong | reply latency ms | longest wait for a reply ms "
          "| worst latency ms | plan wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        tmp = args.keep or scratch
        for row, (name, ftm, fault) in enumerate(ROWS):
            if not any(name == o[1:] if o.startswith("=") else o in name for o in args.only.split(",")):
                continue
            runs = [measure(ftm, fault, args.hz, Path(tmp) / f"row{row}-run{i}", args.seconds,
                            tuple(shlex.split(args.plan_args))) for i in range(args.runs)]
            ok = [r for r in runs if r["ok"]]
            lat = [x for r in ok for x in r["lat"]]
            print(f"| {ftm or 'none'} | {fault} | {len(runs)} | {len(runs) - len(ok)} | "
                  f"{three([r['lost'] for r in ok], '{:.0f}')} | {three([r['dup'] for r in ok], '{:.0f}')} | "
                  f"{three([r['wrong'] for r in ok], '{:.0f}')} | {three(lat, scale=1000)} | "
                  f"{three([r['silence'] for r in ok], scale=1000) if fault != 'none' else '-'} | "
                  f"{three([r['worst'] for r in ok], scale=1000)} | "
                  f"{three([r['wall'] for r in ok]) if fault.startswith('to ') else '-'} |", flush=True)
            behind = [r["behind"] for r in ok if r["behind"]]
            if behind:
                print(f"  ({len(behind)} of {len(ok)} runs still draining when judged: up to {max(behind)} "
                      "requests not answered yet, none skipped)", flush=True)
            if fault == "crash":
                print(f"  (the backup's silence limit at the crash: {three([r['limit'] for r in ok], '{:.3f}')} s)",
                      flush=True)
            for r in runs:
                if not r["ok"]:
                    print(f"  (failed: {r['why']})", flush=True)
            if fault.startswith("to "):
                spans = [r["degraded"] for r in ok if r["degraded"]]
                print(f"  ({'.'.join(CLIENT_USE)} degraded, by the executor's step times: "
                      f"{three([m for m, _ in spans], '{:.2f}')} s; the plan's estimate: "
                      f"{three([e for _, e in spans], '{:.2f}')} s)", flush=True)
                named = sorted({n for r in ok for n in r["named"]})
                print(f"  (the executor named a monitor that saw a violation in {sum(bool(r['named']) for r in ok)} "
                      f"of {len(ok)} runs: {', '.join(named) or 'none'})", flush=True)


if __name__ == "__main__":
    main()
