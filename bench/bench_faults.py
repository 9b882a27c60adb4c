"""A fault campaign on live plans (docs/executor.md#failure-and-recovery): whatever happens to a
plan or the nodes under it, `reconf recover` brings the system back to a valid configuration and
says what it did, truthfully.

Each run (seeded: run i is the same every time) deploys an example with one process per
component, runs the plan script of a change on it and, at a random step, injects one fault:

- `kill-node`:      SIGKILL to the process of a component the plan touches (one that runs that
                    component alone: not an FTM host's, which is a host crash);
- `sigstop`:        SIGSTOP for 3 s to such a process;
- `script-sigint`:  SIGINT to the plan script (it stops at the step's end and writes its report);
- `script-sigkill`: SIGKILL to the plan script (no report; the nodes it started keep running).

Then the recovery the run offers: `reconf recover REPORT --yes` (on to the target or, one run in
two, `--back`) when the script wrote a report it could read whole, else `reconf recover --live
-f ARCH --yes` (ARCH the deployed architecture; for the FTM transition, its target's expansion:
going back by the recovery's generic plan does not keep the mechanism's request path, and the
client's requests are lost, see docs/executor.md#failure-and-recovery). Its own probe (`bench/probe.py`: rclpy, none of the executor's code) reads the
live graph after the script and after the recovery, and the run passes when every report agrees
with it (the configuration the script observed, the one `--live` read, the one the recovery
ended in), the configuration after the recovery is valid (by the plan's model), every node is
active, no process a plan started is left but the nodes of that configuration, and no output
holds a traceback. Prints one line per run and a table per fault kind: the runs passing each
check, and the recovery's wall time (median, p95).

    python -m bench.bench_faults [--runs 25] [--seed-start 0] [--only chatter,chain5] [--json out.json]
    python -m bench.bench_faults --combine a.json b.json       # one table of several chunks' runs

Scenarios, one per run in turn with the fault kinds (run i: kind i mod 4, scenario (i div 4) mod 5):
chatter (replace talker), robot (remove obstacle_detector), chain5 (replace stage0), redundant
(replace lidar_rear) and ftm (the PBR → LFR transition of examples/ftm/client_server_pbr_tr.arch,
its demo client sending). Live runs take a shared lock: run under `flock /tmp/reconf-live.lock`.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional

from checker.semantic_model.actions import failing_assumptions
from checker.semantic_model.config import Configuration
from codegen.ros2 import system_from_model_data
from reconf_dsl.loader import load
from reconf_ros.nodes.ftm.hosts import by_host
from reconf_ros.tools.livetest import LiveSystem, alive

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"
KINDS = ("kill-node", "sigstop", "script-sigint", "script-sigkill")
STOP_SECONDS = 3.0
RECONF = os.path.join(os.path.dirname(sys.executable), "reconf")


@dataclass(frozen=True)
class Scenario:
    name: str
    arch: str                    # the deployed architecture (examples/...)
    plan: tuple[str, ...]        # `reconf plan` arguments, -f ARCH added
    ftm: str = ""                # the server's mechanism to deploy, for an FTM transition (the
                                 # fault model its destination tolerates declared: faults_towards)


SCENARIOS = (
    Scenario("chatter", "chatter.arch", ("replace", "talker")),
    Scenario("robot", "robot.arch", ("remove", "obstacle_detector")),
    Scenario("chain5", "chain5.arch", ("replace", "stage0")),
    Scenario("redundant", "redundant.arch", ("replace", "lidar_rear")),
    Scenario("ftm", "ftm/client_server_pbr_tr.arch", ("transition", "server", "LFR"), ftm="PBR"),
)


@dataclass
class Run:
    seed: int
    scenario: str
    kind: str
    step: int = 0                 # the step the fault was injected at
    target: str = ""              # the component (or "script")
    late: bool = False            # the fault struck once the script had read the system for its report
    struck_at: float = 0.0        # when (wall clock)
    plan_exit: Optional[int] = None
    outcome: str = ""             # the script's report's outcome, or "no report"
    recovery: str = ""            # "report", "report --back", "live", "none"
    recovery_exit: Optional[int] = None
    recovery_outcome: str = ""    # its report's: "done", or "violated" (a monitor saw a violation during it)
    recovery_s: float = 0.0
    report_true: bool = True      # every report (and the --live reading) agreed with the probe
    valid: bool = False           # after the recovery, by the probe
    no_orphan: bool = False
    tracebacks: int = 0
    problems: list[str] = field(default_factory=list)

    @property
    def recovered(self) -> bool:
        """The recovery (if one was needed) carried out every step: done, or done with a monitor
        that saw a violation on the way (said, exit 1)."""
        return self.recovery == "none" or self.recovery_outcome in ("done", "violated", "nothing to do")

    @property
    def ok(self) -> bool:
        return self.report_true and self.valid and self.no_orphan and not self.tracebacks and self.recovered


# --- the probe's reading as a configuration -------------------------------------------------

def probe(live: LiveSystem, name: str) -> dict[str, Any]:
    out = live.dir / f"{name}.json"
    res = subprocess.run([sys.executable, "-m", "bench.probe", "--out", str(out)], env=live.env, cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    if res.returncode != 0:
        raise RuntimeError(f"the probe failed: {res.stderr[-2000:]}")
    return dict(json.loads(out.read_text()))


def as_configuration(seen: dict[str, Any], comps: set[str], placed: dict[str, str],
                     renames: dict[str, str]) -> tuple[Configuration, list[str], dict[str, dict[str, Any]]]:
    """The probe's reading in the components' names (a node's: its placement, else its creation
    mark's component, else its own name), the problems (a node that did not answer, is not a
    component, or is not active), and each component's node."""
    by_node = {n: c for c, n in placed.items()}
    wire = {v: k for k, v in renames.items()}
    present, degraded, roles, problems = set(), set(), set(), []
    nodes: dict[str, dict[str, Any]] = {}
    for fqn, info in sorted(seen["nodes"].items()):
        name = fqn.rsplit("/", 1)[1]
        mark = (info.get("created") or "").split(" ", 1)[-1] if info.get("created") else ""
        comp = by_node.get(name) or (mark if mark in comps else "") or (name if name in comps else "")
        if not info.get("answered"):
            problems.append(f"{fqn} did not answer the probe ({info.get('why', '')})")
            continue
        if info.get("model") is None:
            continue                # not a reconf node (a tool of the test)
        if not comp:
            problems.append(f"{fqn} is no component of the model ({info.get('lifecycle')})")
            continue
        if info.get("lifecycle") == "finalized":
            continue                # removed: a node of a shared process leaves the graph shortly
        nodes[comp] = {**info, "fqn": fqn}
        if info.get("lifecycle") != "active":
            problems.append(f"{fqn} ({comp}) is {info.get('lifecycle')}")
            continue
        present.add(comp)
        degraded |= {(comp, f) for f, m in info["modes"].items() if m != "normal"}
        roles |= {(wire.get(k, k), comp, p) for p, ks in info["ports"].items() for k in ks}
    return Configuration(frozenset(present), frozenset(degraded), frozenset(roles)), problems, nodes


def from_doc(doc: dict[str, Any]) -> Configuration:
    return Configuration(frozenset(doc["components"]), frozenset(tuple(d) for d in doc["degraded"]),
                         frozenset(tuple(r) for r in doc["roles"]))


def differences(said: Configuration, seen: Configuration, skip: set[str]) -> list[str]:
    out = []
    for part in ("components", "degraded", "roles"):
        a = {x for x in getattr(said, part) if (x if isinstance(x, str) else x[0 if part == "degraded" else 1]) not in skip}
        b = {x for x in getattr(seen, part) if (x if isinstance(x, str) else x[0 if part == "degraded" else 1]) not in skip}
        if a != b:
            out.append(f"{part}: said {sorted(a - b)} not seen, seen {sorted(b - a)} not said")
    return out


# --- one run ------------------------------------------------------------------------------

class Script:
    """A plan script (or a recovery) run with its output read line by line."""

    def __init__(self, argv: list[str], live: LiveSystem, log: Path) -> None:
        self.lines: list[str] = []
        self.log = log
        self.t0 = time.monotonic()
        self.proc = subprocess.Popen(argv, env=live.env, cwd=live.dir, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, start_new_session=True)
        live.pids.add(self.proc.pid)
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    def wait_for(self, pattern: str, timeout: float) -> Optional[re.Match[str]]:
        end, seen = time.monotonic() + timeout, 0
        while time.monotonic() < end:
            while seen < len(self.lines):
                m = re.search(pattern, self.lines[seen])
                seen += 1
                if m:
                    return m
            if self.proc.poll() is not None and seen >= len(self.lines):
                self.reader.join(timeout=1)
                if seen >= len(self.lines):
                    return None
            time.sleep(0.01)
        return None

    def finish(self, timeout: float) -> int:
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        self.reader.join(timeout=5)
        self.seconds = time.monotonic() - self.t0
        self.log.write_text("".join(self.lines))
        return code

    @property
    def text(self) -> str:
        return "".join(self.lines)

    def started(self) -> dict[str, int]:
        return {m.group(1): int(m.group(2)) for m in re.finditer(r"started (\S+): pid (\d+)", self.text)}


def deploy(live: LiveSystem, sc: Scenario) -> tuple[str, dict[str, int]]:
    """The scenario's system, one process per component (per host for an FTM); its
    architecture as deployed and each component's process."""
    if sc.ftm:
        arch = live.with_ftm(str(EX / sc.arch), sc.ftm, towards=sc.plan[-1])
        hosts, _ = live.serve_ftm(arch, "", 10.0)
        expanded = str(live.dir / "expanded.arch")
        pids = {c: hosts[h] if h in hosts else hosts.get(c, 0) for h, names in by_host(expanded).items() for c in names}
        return arch, {c: p for c, p in pids.items() if p}
    arch = str(EX / sc.arch)
    procs = live.deploy(arch, group=False)
    names = [c.name for c in load([arch]).components]
    live.wait_ready(timeout=40)
    return arch, {n: p.pid for n, p in zip(names, procs)}


def plan_script(sc: Scenario, arch: str, work: Path, cache: dict[str, Path]) -> Path:
    """The scenario's plan script (made once per scenario and architecture text)."""
    key = f"{sc.name}:{Path(arch).read_text()}"
    if key not in cache:
        out = work / f"plan-{sc.name}-{len(cache)}.py"
        res = subprocess.run([RECONF, "plan", *sc.plan, "-f", arch, "--no-alloy", "-o", str(out)],
                             capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"reconf plan {' '.join(sc.plan)}: {res.stderr}")
        cache[key] = out
    return cache[key]


def inject(run: Run, rng: random.Random, script: Script, steps: list[dict[str, Any]],
           pids: dict[str, int], live: LiveSystem) -> Callable[[], None]:
    """Wait for the chosen step, then strike; the call that ends the fault (a SIGCONT)."""
    run.step = rng.randint(1, len(steps))
    delay = rng.uniform(0.0, 0.05)     # most steps take milliseconds: strike while this one runs
    if not script.wait_for(rf"^\s*{run.step}\. .* \.\.\.$", 120):
        run.problems.append(f"the script never reached step {run.step}")
        return lambda: None
    time.sleep(delay)
    run.late, run.struck_at = script.proc.poll() is not None, time.time()
    if run.kind.startswith("script"):
        run.target = "script"
        os.kill(script.proc.pid, signal.SIGINT if run.kind == "script-sigint" else signal.SIGKILL)
        return lambda: None
    pids = {**pids, **script.started()}
    shared = {p for p in pids.values() if list(pids.values()).count(p) > 1}   # an FTM host's process: not one node
    touched = sorted({s["component"] for s in steps} & {c for c, p in pids.items() if alive(p) and p not in shared})
    if not touched:
        run.problems.append("no process of a component the plan touches was running")
        return lambda: None
    run.target = rng.choice(touched)
    pid = pids[run.target]
    if run.kind == "kill-node":
        os.kill(pid, signal.SIGKILL)
        return lambda: None
    os.kill(pid, signal.SIGSTOP)
    timer = threading.Timer(STOP_SECONDS, lambda: os.kill(pid, signal.SIGCONT) if alive(pid) else None)
    timer.start()
    return timer.join


def judge(model_doc: dict[str, Any], seen: dict[str, Any], placed: dict[str, str],
          renames: dict[str, str]) -> tuple[Configuration, list[str], dict[str, dict[str, Any]]]:
    """The probe's reading as a configuration of the plan's model, with what is wrong with it:
    a node that is not an active component, an assumption that does not hold."""
    system = system_from_model_data(model_doc)
    comps = {c.name for c in system.components + system.versions}
    config, problems, nodes = as_configuration(seen, comps, placed, renames)
    problems += [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in failing_assumptions(system, config)]
    return config, problems, nodes


def recover(run: Run, rng: random.Random, live: LiveSystem, report: dict[str, Any], arch: str,
            use_alloy: bool, healthy: bool) -> Optional[Script]:
    """The recovery the run offers: from its report (unless the plan was done, and the system
    is still `healthy`, or the report could not read every node), else from the live system."""
    base = ["--yes", "--log-dir", str(live.dir / "logs"), "--report", str(live.dir / "recovered.json")]
    base += [] if use_alloy else ["--no-alloy"]
    if report.get("outcome") == "done" and healthy:
        run.recovery = "none"
        return None
    if report.get("observed") and not report.get("unread") and report["outcome"] != "done":
        back = rng.random() < 0.5
        run.recovery = "report --back" if back else "report"
        argv = [RECONF, "recover", str(live.dir / "report.json"), *(["--back"] if back else []), *base]
    else:
        run.recovery = "live"
        if run.scenario == "ftm":   # on to the transition's target: its new nodes are adopted
            last = SCENARIOS[-1]
            target = live.with_ftm(str(EX / last.arch), last.plan[-1], name="target.arch", towards=last.plan[-1])
            arch = live.expanded(target, name="target-expanded.arch")
        argv = [RECONF, "recover", "--live", "-f", arch, *base]
    script = Script(argv, live, live.dir / "recover.out")
    run.recovery_exit = script.finish(300)
    run.recovery_s = round(script.seconds, 2)
    return script


def check_report(run: Run, report: dict[str, Any], seen: dict[str, Any], what: str) -> None:
    """The configuration a report says it observed, against the probe's reading."""
    doc = report["plan_document"]
    comps = {c["name"] for c in doc["model"]["components"]}
    placed = report.get("placed") or {}
    config, _, _ = as_configuration(seen, comps, placed, doc["plan"].get("renames") or {})
    diffs = differences(from_doc(report["observed"]), config, set(report.get("unread") or []))
    if diffs:
        run.report_true = False
        run.problems.append(f"{what} disagrees with the probe: " + "; ".join(diffs))


def check_live_reading(run: Run, recovered: dict[str, Any], seen: dict[str, Any]) -> None:
    """What `reconf recover --live` read (its plan's first state) against the probe."""
    doc = recovered["plan_document"]
    plan = doc["plan"]
    comps = {c["name"] for c in doc["model"]["components"]}
    placed = (plan.get("recovery") or {}).get("placed") or {}
    config, _, _ = as_configuration(seen, comps, placed, plan.get("renames") or {})
    diffs = differences(from_doc(plan["start"]), config, set())
    if diffs:
        run.report_true = False
        run.problems.append("the --live reading disagrees with the probe: " + "; ".join(diffs))


def check_end(run: Run, model_doc: dict[str, Any], seen: dict[str, Any], placed: dict[str, str],
              renames: dict[str, str], pids: set[int]) -> None:
    """After the recovery: valid by the plan's model, every node active and a component, and no
    process a plan started left but the nodes of that configuration."""
    config, problems, nodes = judge(model_doc, seen, placed, renames)
    run.valid = not problems
    run.problems += problems
    kept = {n.get("pid") for c, n in nodes.items() if c in config.components}
    left = sorted(p for p in pids if alive(p) and p not in kept)
    run.no_orphan = not left
    if left:
        run.problems.append(f"processes a plan started left running: {left}")


def one_run(seed: int, work: Path, cache: dict[str, Path], only: set[str], use_alloy: bool) -> Optional[Run]:
    rng = random.Random(seed)
    kind = KINDS[seed % len(KINDS)]
    sc = SCENARIOS[(seed // len(KINDS)) % len(SCENARIOS)]
    if only and sc.name not in only:
        return None
    run = Run(seed, sc.name, kind)
    with LiveSystem(work / f"run-{seed:03d}") as live:
        live.watch()
        arch, pids = deploy(live, sc)
        script_path = plan_script(sc, arch, work, cache)
        doc = json.loads(script_path.read_text().split('DOC = json.loads(r"""', 1)[1].split('"""', 1)[0])
        script = Script([sys.executable, str(script_path), "--yes", "--log-dir", str(live.dir / "logs"),
                         "--report", str(live.dir / "report.json")], live, live.dir / "plan.out")
        resume = inject(run, rng, script, doc["plan"]["steps"], pids, live)
        run.plan_exit = script.finish(240)
        resume()
        started = set(script.started().values())
        live.pids |= started
        report = live.report()
        run.outcome = report.get("outcome", "no report")
        # a fault after the reading the report gives (its observed_at) is not in it: the report
        # was true when read, and the recovery starts from what the probe sees
        run.late = run.late or (run.struck_at > 0 and report.get("observed_at") is not None
                                and run.struck_at >= report["observed_at"])
        first = probe(live, "probe-after-plan")
        if report.get("observed") and not run.late:
            check_report(run, report, first, "the run's report")
        renames = doc["plan"].get("renames") or {}
        healthy = not judge(doc["model"], first, report.get("placed") or {}, renames)[1]
        rec = recover(run, rng, live, report, arch, use_alloy, healthy)
        recovered = live.report("recovered.json")
        run.recovery_outcome = recovered.get("outcome", "")
        if rec is not None and rec.proc.returncode == 0 and "nothing to recover" in " ".join(rec.text.split()):
            run.recovery_outcome = "nothing to do"
        if rec is not None:
            started |= set(rec.started().values())
            live.pids |= started
        last = probe(live, "probe-after-recovery")
        if run.recovery == "live" and recovered.get("plan_document"):
            check_live_reading(run, recovered, first)
        if recovered.get("observed"):
            check_report(run, recovered, last, "the recovery's report")
        end = recovered or report
        placed = end.get("placed") or {}
        renames = end.get("plan_document", doc)["plan"].get("renames") or {}
        check_end(run, doc["model"], last, placed, renames, started)
        texts = [script.text] + ([rec.text] if rec is not None else [])
        run.tracebacks = sum(t.count("Traceback") for t in texts)
        if not run.recovered:
            run.problems.append(f"the recovery exited {run.recovery_exit}: {rec.text[-1500:] if rec else ''}")
    return run


# --- the campaign -------------------------------------------------------------------------

def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def table(runs: list[Run]) -> str:
    head = ("| fault | runs | report true | recovered | valid after | no orphan | tracebacks | all | "
            "violation seen during recovery | recoveries run | recovery s median | p95 |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = [head]
    for kind in KINDS + ("all",):
        rs = [r for r in runs if kind in ("all", r.kind)]
        if not rs:
            continue
        secs = [r.recovery_s for r in rs if r.recovery not in ("none", "")]
        rows.append(f"| {kind} | {len(rs)} | {sum(r.report_true for r in rs)} | {sum(r.recovered for r in rs)} | "
                    f"{sum(r.valid for r in rs)} | {sum(r.no_orphan for r in rs)} | {sum(r.tracebacks for r in rs)} | "
                    f"{sum(r.ok for r in rs)} | {sum(r.recovery_outcome == 'violated' for r in rs)} | {len(secs)} | "
                    f"{statistics.median(secs) if secs else float('nan'):.1f} | {pct(secs, 0.95):.1f} |")
    return "\n".join(rows)


def campaign(runs: int, seed_start: int = 0, only: tuple[str, ...] = (), use_alloy: bool = True,
             work: Optional[Path] = None, say: Callable[[str], None] = print) -> list[Run]:
    """`runs` runs from `seed_start`; each line said as it ends."""
    unknown = set(only) - {s.name for s in SCENARIOS}
    if unknown:
        raise ValueError(f"no scenario {', '.join(sorted(unknown))}: choose among {', '.join(s.name for s in SCENARIOS)}")
    base = work or Path(tempfile.mkdtemp(prefix="bench_faults_"))
    cache: dict[str, Path] = {}
    out: list[Run] = []
    seed = seed_start
    while len(out) < runs:
        if only and seed - seed_start > 1000:
            break
        run = one_run(seed, base, cache, set(only), use_alloy)
        seed += 1
        if run is None:
            continue
        out.append(run)
        say(f"run {run.seed:3d} {run.scenario:9s} {run.kind:14s} step {run.step}{' (late)' if run.late else ''} "
            f"{run.target:>16s}: plan exit "
            f"{run.plan_exit} ({run.outcome}), recovery {run.recovery or '-'} exit {run.recovery_exit} "
            f"({run.recovery_outcome or '-'}) in "
            f"{run.recovery_s:.1f} s: {'ok' if run.ok else 'FAILED: ' + ' | '.join(run.problems)}")
    if work is None:
        shutil.rmtree(base, ignore_errors=True)
    return out


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_faults", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=25)
    ap.add_argument("--seed-start", type=int, default=0)
    ap.add_argument("--only", default="", help="scenarios, comma-separated (default: all)")
    ap.add_argument("--no-alloy", action="store_true", help="recover with --no-alloy (Alloy verifies by default)")
    ap.add_argument("--json", default="", help="also write every run here")
    ap.add_argument("--keep", default="", help="keep the runs' directories here")
    ap.add_argument("--combine", nargs="+", default=[], metavar="JSON",
                    help="print the table of the runs these --json files hold (chunks of one campaign), run nothing")
    args = ap.parse_args(argv)
    if args.combine:
        runs = [Run(**r) for f in args.combine for r in json.loads(Path(f).read_text())]
        print(table(runs))
        return 0 if runs and all(r.ok for r in runs) else 1
    only = tuple(s for s in args.only.split(",") if s)
    try:
        runs = campaign(args.runs, args.seed_start, only, not args.no_alloy, Path(args.keep) if args.keep else None)
    except ValueError as e:
        print(e, file=sys.stderr)
        return 2
    if not runs:
        print("no run matched --only", file=sys.stderr)
        return 2
    print(table(runs))
    if args.json:
        Path(args.json).write_text(json.dumps([asdict(r) for r in runs], indent=1))
    return 0 if all(r.ok for r in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
