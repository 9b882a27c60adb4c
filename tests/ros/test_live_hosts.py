"""Hosts as real network endpoints (reconf_ros.tools.netlab): each host a network namespace of
its own on a bridge, every node of a host in its namespace, DDS across the hosts' network; plans
that start and stop each component on its host by the host's agent (`--hosts`); and faults of hosts and links: a host crashed (every process of it killed), cut off (its link down)
or losing packets (nftables). The FTM of paper 000 survives a crash and a partition of the
primary's host, and the old primary, healed, answers nothing: it fenced itself."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

import pytest

from reconf_ros.demo.ftm import read_log, wait_replies
from reconf_ros.demo.history import check_history
from reconf_ros.nodes.ftm.detect import replica_nodes
from reconf_ros.tools.livetest import LiveSystem, alive
from reconf_ros.tools.netlab import hosts_of, nft_available

from .conftest import example

HZ = 20         # requests/s (bench_hosts: 50)


def received(live: LiveSystem) -> int:
    return int(live.statuses().get("/listener", {}).get("values", {}).get("in.in.received", "0"))


def test_two_hosts_talk_over_their_network_and_a_partition_cuts_them(on_hosts: Callable[..., LiveSystem]) -> None:
    live = on_hosts(["robot", "station"], home="station")
    assert live.lab is not None
    procs = live.deploy_by_host(example("chatter_hosts.arch"))
    live.wait_ready(["talker", "listener"], timeout=60)
    # each host's process runs in its host's namespace; the watcher, on the station, hears the robot's
    assert procs["robot"] in live.lab.pids("robot") and procs["robot"] not in live.lab.pids("station")
    assert procs["station"] in live.lab.pids("station")
    assert live.statuses()["/talker"]["values"]["lifecycle"] == "active"
    live.partition("robot")
    time.sleep(1.0)
    before = received(live)
    assert live.wait(lambda st: st["/listener"]["values"].get("wire.listen", "").startswith("not met"), 5), \
        live.statuses().get("/listener")
    time.sleep(1.0)
    assert received(live) == before, "a message crossed the partition"
    live.heal("robot")
    live.wait_ready(["listener"], timeout=30)
    assert received(live) > before


def reconf_on(live: LiveSystem, *args: str, report: str) -> subprocess.CompletedProcess[str]:
    """`reconf ARGS` on the lab's home host (a plan applied with its logs and its report here);
    the processes its report names are ended with the system."""
    argv = [str(Path(sys.executable).with_name("reconf")), *args, "--no-alloy", "--yes",
            "--log-dir", str(live.dir / "logs"), "--report", str(live.dir / report)]
    res = subprocess.run(live.on_host(None, argv), capture_output=True, text=True, env=live.env, cwd=live.dir,
                         timeout=180)
    live.pids.update(int(s["pid"]) for s in live.report(report).get("started", {}).values())
    return res


def test_up_starts_each_component_on_its_host_by_its_agent_and_a_managed_replace_runs_through_it(
        on_hosts: Callable[..., LiveSystem]) -> None:
    """`up --hosts` applied from its own process, then a replace applied by a manager (`--manager`)
    with the same hosts file: both start each new node on its host by that host's agent."""
    live = on_hosts(["robot", "station"], home="station")
    assert live.lab is not None
    hosts_file = live.agents()
    arch = example("chatter_hosts.arch")
    up = reconf_on(live, "up", arch, "--hosts", str(hosts_file), report="up.json")
    assert up.returncode == 0, up.stdout + up.stderr
    started = live.report("up.json")["started"]
    assert {c: s.get("host") for c, s in started.items()} == {"talker": "robot", "listener": "station"}
    for comp, host, other in (("talker", "robot", "station"), ("listener", "station", "robot")):
        pid = int(started[comp]["pid"])
        assert pid in live.lab.pids(host) and pid not in live.lab.pids(other), (comp, host)
        assert started[comp]["log"].startswith(str(hosts_file.parent / host)), started[comp]     # the agent's log
        assert re.search(rf"started {comp}: pid {pid} on host {host}", up.stdout + up.stderr), up.stdout
    statuses = live.settle_status(["talker", "listener"])
    assert int(statuses["/talker"]["values"]["pid"]) == int(started["talker"]["pid"])
    assert live.violations(statuses) == {}
    # the replace of the robot's talker, applied by a manager on the station: the robot's agent
    # starts talker_v2 and reports the old talker's exit
    script = live.plan_script(["replace", "talker", "-f", arch, "--with", "talker_v2"])
    manager = live.manager()
    res = live.run_plan(script, "--hosts", str(hosts_file), "--manager", manager, timeout=120)
    report = live.report()
    assert res.returncode == 0 and report["outcome"] == "done", res.stdout + res.stderr
    v2 = report["started"]["talker_v2"]
    assert v2["host"] == "robot" and int(v2["pid"]) in live.lab.pids("robot"), v2
    assert re.search(rf"talker: its process \(pid {started['talker']['pid']} on host robot\) exited with status 0",
                     res.stdout), res.stdout
    assert int(started["talker"]["pid"]) not in live.lab.pids("robot")
    # the old talker, seen to exit by its agent, is read as absent, not asked again (its node
    # lingers in the station's graph for seconds, and asking it waited for the timeout, 5 s)
    remove = next(t for t in report["timings"] if t.get("action", "").startswith("remove"))
    assert remove["seconds"] < 3.0, remove
    assert re.search(r"none of the \d+ monitors heard from saw a normal mode's assumption violated", res.stdout), \
        res.stdout
    assert live.violations(live.settle_status(["listener"])) == {}


def test_a_step_on_a_host_whose_agent_cannot_be_reached_fails_naming_the_host(
        on_hosts: Callable[..., LiveSystem]) -> None:
    live = on_hosts(["robot", "station"], home="station")
    assert live.lab is not None
    hosts_file = live.agents()
    arch = example("chatter_hosts.arch")
    running = {h: set(live.lab.pids(h)) for h in ("robot", "station")}     # the agents (and their launchers)
    live.partition("robot")         # the robot cut off: its agent cannot be reached
    t0 = time.monotonic()
    up = reconf_on(live, "up", arch, "--hosts", str(hosts_file), "--timeout", "2", report="unreachable.json")
    report = live.report("unreachable.json")
    assert up.returncode == 1 and report["outcome"] == "failed", up.stdout + up.stderr
    assert time.monotonic() - t0 < 60
    address = json.loads(hosts_file.read_text())["hosts"]["robot"]
    assert report["failed_step"] == 1 and report["failed_host"] == "robot", report["reason"]
    assert report["reason"].startswith(f"host robot ({address}) cannot be reached: "), report["reason"]
    assert re.search(rf"step 1 \(create talker.*?\) FAILED: host robot \({re.escape(address)}\) cannot be reached",
                     up.stderr), up.stderr
    assert report["started"] == {}      # nothing started, here or elsewhere
    assert {h: set(live.lab.pids(h)) for h in running} == running
    live.heal("robot")
    # a hosts file that does not name the robot: the same, never a start on this host instead
    partial = live.dir / "agents" / "station-only.json"
    doc = json.loads(hosts_file.read_text())
    partial.write_text(json.dumps({**doc, "hosts": {"station": doc["hosts"]["station"]}}))
    up = reconf_on(live, "up", arch, "--hosts", str(partial), report="unnamed.json")
    report = live.report("unnamed.json")
    assert up.returncode == 1 and report["failed_host"] == "robot", up.stdout + up.stderr
    assert report["reason"] == f"host robot is not in the hosts file {partial} (it names station)", report["reason"]
    assert report["started"] == {}
    assert {h: set(live.lab.pids(h)) for h in running} == running
    # with every host reachable, up and then down: each remove waits for its agent's report of the exit
    assert reconf_on(live, "up", arch, "--hosts", str(hosts_file), report="up.json").returncode == 0
    pids = {c: int(s["pid"]) for c, s in live.report("up.json")["started"].items()}
    down = reconf_on(live, "down", arch, "--hosts", str(hosts_file), report="down.json")
    assert down.returncode == 0, down.stdout + down.stderr
    for comp, host in (("talker", "robot"), ("listener", "station")):
        assert f"{comp}: its process (pid {pids[comp]} on host {host}) exited with status 0" in down.stdout, down.stdout
    assert {h: set(live.lab.pids(h)) for h in running} == running, "a process outlived reconf down"


def test_discover_and_drift_on_one_host_read_every_hosts_nodes(on_hosts: Callable[..., LiveSystem]) -> None:
    live = on_hosts(["robot", "station"], home="station")
    arch = example("chatter_hosts.arch")
    live.deploy_by_host(arch)
    live.wait_ready(["talker", "listener"], timeout=60)

    def reconf(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(live.on_host("station", [sys.executable, "-m", "checker", *args]), capture_output=True,
                              text=True, env=live.env, cwd=live.dir, timeout=120)
    found = reconf("discover", "-o", "found.arch")
    assert found.returncode == 0, found.stderr
    assert "wrote found.arch: 2 reconf nodes, 0 placeholders" in found.stderr
    drift = reconf("drift", arch)
    assert drift.returncode == 0 and "in sync" in drift.stdout + drift.stderr, drift.stdout + drift.stderr
    live.partition("robot")         # the talker gone from where the station reads: drift says so
    time.sleep(25.0)                # Fast DDS forgets a participant it has not heard for 20 s
    drift = reconf("drift", arch, "--settle", "10")
    assert drift.returncode == 1 and "RC611" in drift.stdout + drift.stderr, drift.stdout + drift.stderr


@pytest.mark.skipif(nft_available() is not None, reason=str(nft_available()))
def test_a_lossy_link_delivers_what_reliability_recovers(on_hosts: Callable[..., LiveSystem]) -> None:
    live = on_hosts(["robot", "station"], home="station")
    assert live.lab is not None
    live.deploy_by_host(example("chatter_hosts.arch"))
    live.wait_ready(["talker", "listener"], timeout=60)
    live.loss("robot", 30)
    assert "numgen random mod 1000 < 300 drop" in live.lab.faults("robot")
    before, deadline = received(live), time.monotonic() + 12.0
    # reliable delivery is in order: a lost sample holds back those after it until the writer's
    # next heartbeat (Fast DDS: every 3 s) has it sent again, so the stream comes in bursts
    while received(live) - before < 15 and time.monotonic() < deadline:
        time.sleep(0.2)
    assert received(live) - before >= 15, "a 30 % loss stopped the stream"     # 120 sent by the deadline
    live.heal("robot")
    assert live.lab.faults("robot") == "none"


@pytest.mark.skipif(nft_available() is not None, reason=str(nft_available()))
def test_a_plan_on_a_lossy_link_ends_done_or_says_truly_what_it_saw(on_hosts: Callable[..., LiveSystem]) -> None:
    """The chatter replace across two hosts while 10 % of the robot's packets are dropped each
    way: the plan ends (done, done with a violation the monitors saw, or failed), never hangs or
    crashes, and the configuration its report says it observed is what bench.probe reads."""
    from bench.bench_hosts import judge_report
    live = on_hosts(["robot", "station"], home="station")
    hosts_file = live.agents()
    arch = example("chatter_hosts.arch")
    live.deploy_by_host(arch)
    live.wait_ready(["talker", "listener"], timeout=60)
    script = live.plan_script(["replace", "talker", "-f", arch, "--with", "talker_v2"])
    live.loss("robot", 10)
    res = live.run_plan(script, "--hosts", str(hosts_file), timeout=240)
    live.heal("robot")
    out = res.stdout + res.stderr
    report = live.report()
    assert "Traceback" not in out and report.get("outcome") in ("done", "violated", "failed"), out[-3000:]
    assert res.returncode == (0 if report["outcome"] == "done" else 1), out[-3000:]
    true, why_not = judge_report(live, report)
    assert true, (why_not, out[-4000:])
    if report["outcome"] == "violated":      # what the monitors saw, said as seen
        assert re.search(r"monitor of \w+ saw \d+ violations? of a normal mode's assumption", out), out[-3000:]


def serve(live: LiveSystem, ftm: str) -> Path:
    _, log = live.serve_ftm(example("ftm/client_server_pbr_tr.arch"), ftm, HZ)
    assert wait_replies(log, 20, timeout=60), f"no replies: {live.statuses()}"
    assert live.wait_detectors_armed(timeout=30), live.statuses()
    return log


def judged(log: Path) -> dict[str, Any]:
    """The client's whole history, once it has had time to catch up: no anomaly and nothing lost."""
    time.sleep(2.0)
    return check_history(read_log(log), until=time.time() - 1.5)


def replica0(live: LiveSystem) -> list[str]:
    from reconf_dsl.loader import load
    return replica_nodes(load([str(live.dir / "expanded.arch")]), "server", 0)


@pytest.mark.parametrize("ftm", ["PBR", "LFR"])
def test_the_backup_takes_over_from_a_partitioned_primary_which_fences_itself(
        on_hosts: Callable[..., LiveSystem], ftm: str) -> None:
    arch = example("ftm/client_server_pbr_tr.arch")
    live = on_hosts(hosts_of([arch]), home="client_site")
    log = serve(live, ftm)
    cut = time.time()
    live.partition("master")
    assert wait_replies(log, 2 * HZ, timeout=20, after=cut + 0.1), live.statuses()    # the backup serves
    time.sleep(1.0)
    live.heal("master")
    healed = time.time()
    # healed: the old primary's nodes are back in the graph, inactive (fenced), and answer nothing.
    # A node's deactivation degrades its modes first, then detaches its ports one by one, and
    # destroying a reader while its host was cut off once took 2.8 s: a status heard just after
    # healing can show a node still deactivating, already silent
    wanted = replica0(live)

    def fenced(st: dict[str, Any]) -> bool:
        return all(st.get(f"/{n}", {}).get("seen", 0) > healed
                   and st[f"/{n}"]["values"].get("lifecycle") == "inactive" for n in wanted)
    live.wait(fenced, 15)
    st = live.statuses()
    assert {n: st.get(f"/{n}", {}).get("values", {}).get("lifecycle") for n in wanted} == \
        {n: "inactive" for n in wanted}, sorted(st)
    # fenced by its own heartbeat while cut off (a request Recovery sent then may also arrive once healed)
    assert st["/server__r0_cd"]["values"]["app.lease"] == "fenced"
    assert cut < float(st["/server__r0_cd"]["values"]["app.fenced_at"]) < healed
    assert wait_replies(log, 2 * HZ, timeout=20, after=healed)
    verdict = judged(log)
    assert verdict["linearizable"] and verdict["lost"] == [], verdict
    replies = sorted(r[0]["t"] for r in read_log(log)["replies"].values())
    wait = max(b - a for a, b in zip(replies, replies[1:]) if b > cut)
    assert wait < 3.0, f"the client waited {wait:.3f} s for a reply"


def test_the_backup_takes_over_from_a_crashed_host(on_hosts: Callable[..., LiveSystem]) -> None:
    arch = example("ftm/client_server_pbr_tr.arch")
    live = on_hosts(hosts_of([arch]), home="client_site")
    log = serve(live, "PBR")
    crashed = time.time()
    assert live.crash("master"), "nothing ran on the master host"
    assert wait_replies(log, 2 * HZ, timeout=20, after=crashed + 0.1), live.statuses()
    verdict = judged(log)
    assert verdict["linearizable"] and verdict["lost"] == [], verdict


HOSTS_LIVE = "<!-- live on hosts:"
SERVED = ("100 more requests answered", "linearizable, nothing lost")
# what each command of the README's walkthrough must print, in order
HOSTS_SHOWS = [("python -m reconf_ros.tools.netlab up", ("agents/hosts.json",)),
               ("python -m reconf_ros.tools.netlab run station -- reconf up",
                ("reconf will bring chatter_hosts up in", "started talker: pid", "on host robot", "all 6 steps done")),
               ("reconf plan replace talker", ("Wrote replace.py",)),
               ("python -m reconf_ros.tools.netlab run station -- python replace.py",
                ("started talker_v2: pid", "on host robot (forked by the agent's launcher)",
                 "on host robot) exited with status 0", "all 5 steps done",
                 "none of the 3 monitors heard from saw a normal mode's assumption violated")),
               ("python -m reconf_ros.tools.netlab down", ("lab lab removed",)),
               ("reconf ftm expand", ("expanded 1 FTM into 20 components",)),
               ("python -m reconf_ros.tools.netlab up pbr_tr.arch", ("client_site: ", "master: ", "slave: ")),
               ("export RECONF_CLIENT_HZ=20; for host in", ()),
               ("python -m reconf_ros.demo.history", SERVED),
               ("python -m reconf_ros.tools.netlab partition master", ("master: faults: link down",)),
               ("python -m reconf_ros.demo.history", SERVED),
               ("python -m reconf_ros.tools.netlab heal master", ("master: faults: none",)),
               ("python -m reconf_ros.demo.history", SERVED),
               ("python -m reconf_ros.tools.netlab down", ("lab lab removed",))]


def test_the_readme_s_many_hosts_walkthrough_runs_as_written(tmp_path: Path) -> None:
    """The README's block after `<!-- live on hosts: ... -->`, line by line in a copy of the
    examples: a lab of two hosts with an agent on each, `up` and a replace of the robot's talker
    through the agents, the lab removed; then PBR(TR) on a lab of three hosts under a client, its
    primary's host cut off and healed, the client's whole history judged after each; each line
    exits 0 and says what it shows, no process of a lab outlives it, and the lab is removed even
    when a line fails."""
    from reconf_ros.tools.netlab import RECORDS, NetLab, lab_available
    why = lab_available()
    if why:
        pytest.skip(f"a lab of hosts cannot be made here: {why}")
    if (RECORDS / "lab.json").exists():
        pytest.skip("a lab named `lab` exists already on this machine: the walkthrough would use it")
    root = Path(__file__).resolve().parents[2]
    lines = (root / "README.md").read_text(encoding="utf-8").splitlines()
    first = next(i for i, ln in enumerate(lines) if ln.startswith(HOSTS_LIVE)) + 2
    block = [(i + 1, ln) for i, ln in enumerate(lines[first:], first) if ln.strip()]
    block = block[:next(k for k, (_, ln) in enumerate(block) if ln.startswith("```"))]
    import shutil
    shutil.copytree(root / "examples", tmp_path / "examples")
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""),
               PYTHONUNBUFFERED="1")
    shows, started = list(HOSTS_SHOWS), set()
    try:
        for number, line in block:
            command = line.split("  #")[0].strip()
            if command.endswith("netlab down") and (RECORDS / "lab.json").exists():
                lab = NetLab.existing("lab")        # every process of its hosts, which `down` must end
                started |= {p for h in lab.record.hosts for p in lab.pids(h.name)}
            done = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, capture_output=True, text=True,
                                  timeout=180)
            out = done.stdout + done.stderr
            started |= {int(p) for p in re.findall(r"started \w+: pid (\d+)", out)}
            said = f"README.md:{number}: {command}\n{out[-3000:]}"
            assert done.returncode == 0 and "Traceback" not in out, said
            assert shows and command.startswith(shows[0][0]), said
            for text in shows.pop(0)[1]:
                assert text in " ".join(out.split()), said
        assert shows == [], f"not shown: {shows}"
        assert not (RECORDS / "lab.json").exists()
        assert len(started) >= 3 + 3 and not any(alive(p) for p in started), started
    finally:
        if (RECORDS / "lab.json").exists():
            NetLab.existing("lab").down()
