"""Plans carried out on live systems: the model's safety observed on the wire.

Each test deploys an example with its real nodes, plans a change, runs the plan script as a
user would, and asserts what the running system showed: the plan's final state observed by the
executor, no monitor seeing a normal mode's assumption violated, and no message lost by the
new publishers."""
from __future__ import annotations

import os
import re
from typing import Any

import pytest

from reconf_ros.tools.livetest import LiveSystem

from .conftest import example


def source(statuses: dict[str, Any], comp: str, port: str, publisher: str) -> tuple[int, int, int]:
    """(received, lost, missed at its start) of `publisher` as `comp.port` saw it."""
    v = statuses[f"/{comp}"]["values"].get(f"in.{port}.from.{publisher}", "0/0/0")
    received, lost, head = (int(x) for x in v.split("/"))
    return received, lost, head


def applied(live: LiveSystem, res: Any) -> dict[str, Any]:
    assert res.returncode == 0, res.stdout + res.stderr
    assert "monitors heard from saw a normal mode's assumption violated" in res.stdout
    report = live.report()
    assert report["outcome"] == "done"
    statuses = live.settle_status(report["observed"]["components"] if report.get("observed") else ())
    assert live.violations(statuses) == {}, statuses
    return statuses


def planned(live: LiveSystem, arch: str, *plan: str) -> dict[str, Any]:
    """Deploy `arch`, wait until it is up, plan `plan` on it, run the script; what the nodes saw."""
    live.deploy(example(arch))
    live.wait_ready()
    files = [] if plan[0] == "migrate" else ["-f", example(arch)]
    return applied(live, live.run_plan(live.plan_script([*plan, *files])))


@pytest.mark.parametrize("strategy", ["default", "paper"])
def test_replace_talker(live: LiveSystem, strategy: str) -> None:
    """The default strategy's script forks talker_v2 from a launcher of its own, which ends with
    the script (docs/executor.md#launcher), ahead and held until its step (docs/executor.md#held);
    the paper's is run with `--no-launcher`."""
    live.deploy(example("chatter.arch"))
    live.wait_ready()
    script = live.plan_script(["replace", "talker", "--strategy", strategy, "-f", example("chatter.arch")])
    own = strategy == "default"
    res = live.run_plan(script, *([] if own else ["--no-launcher"]))
    statuses = applied(live, res)
    held = re.search(r"started talker_v2: pid (\d+) \(forked by the launcher ([\d.]+) s before, held until now\)",
                     res.stdout)
    assert (held is not None) == own and ("forked by the launcher" in res.stdout) == own, res.stdout
    if held is not None:       # the process held is the one the report names, and none was left held
        assert int(held[1]) == live.pid_of("talker_v2") and "never released" not in res.stdout, res.stdout
    # where the time went: the check's wait for discovery (at least one announcement period and a
    # margin, and the nodes quiet for a while) and its reading; the run's check, steps, the time
    # between them and the final check, adding up to its whole
    check = re.search(r"checked in ([\d.]+) s: waiting for discovery ([\d.]+) s, the graph's last change "
                      r"([\d.]+) s after it began, reading ([\d.]+) s\)", res.stdout)
    assert check is not None and float(check[2]) >= 0.75 and float(check[2]) - float(check[3]) >= 0.5, res.stdout
    run = re.search(r"done in ([\d.]+) s \(checking the live system ([\d.]+) s, steps ([\d.]+) s, between steps "
                    r"([\d.]+) s, the final check ([\d.]+) s\)", res.stdout)
    assert run is not None and abs(sum(float(x) for x in run.groups()[1:]) - float(run[1])) <= 0.02, res.stdout
    # what served and was degraded, by the steps' times, next to the plan's estimate: the paper's
    # order degrades the listener around the talker's replacement, the default's no one
    degraded = re.search(r"degraded on the wire, by the steps' times: listener.listen ([\d.]+) s \(plan ~([\d.]+) s\)",
                         res.stdout)
    if own:
        assert "degraded on the wire: no functionality that served before the run (the plan expected none)" \
            in res.stdout, res.stdout
    else:
        # from the end of step 1 to the end of step 7: within the steps and the time between them
        within = float(run[3]) + float(run[4]) + 0.01
        assert degraded is not None and 0 < float(degraded[1]) <= within and float(degraded[2]) > 0, res.stdout
    assert os.kill(live.pid_of("talker_v2"), 0) is None     # running after the script and its launcher ended
    received, lost, head = source(statuses, "listener", "in", "talker_v2")
    assert received > 0 and lost == 0 and head == 0, statuses["/listener"]["values"]
    assert statuses["/talker_v2"]["values"]["mode.talk"] == "normal"
    assert statuses["/talker"]["values"]["lifecycle"] in ("inactive", "finalized")   # its last status
    gap = float(statuses["/listener"]["values"]["in.in.max_gap_s"])
    assert gap <= 0.15, f"largest gap of the listener while normal: {gap} s"


def test_remove_obstacle_detector(live: LiveSystem) -> None:
    statuses = planned(live, "robot.arch", "remove", "obstacle_detector")
    mc = statuses["/motor_controller"]["values"]
    assert mc["mode.control"] == "degraded" and mc["port.in"] == "/obstacles"   # left degraded: nothing publishes
    assert statuses["/base_driver"]["values"]["mode.drive"] == "normal"


def test_replace_one_of_two_redundant_publishers(live: LiveSystem) -> None:
    statuses = planned(live, "redundant.arch", "replace", "lidar_rear")
    assert statuses["/mapper"]["values"]["mode.map"] == "normal"
    received, lost, head = source(statuses, "mapper", "scan", "lidar_rear_v2")
    assert received > 0 and lost == 0 and head == 0


def test_replace_the_head_of_the_chain(live: LiveSystem) -> None:
    statuses = planned(live, "chain5.arch", "replace", "stage0")
    assert all(statuses[f"/stage{i}"]["values"]["mode.step"] == "normal" for i in range(1, 5))
    assert statuses["/stage0_v2"]["values"]["mode.step"] == "normal"


def test_migration(live: LiveSystem) -> None:
    statuses = planned(live, "chatter.arch", "migrate", example("chatter.arch"), example("chatter_migrated.arch"))
    for comp in ("listener", "logger"):
        received, lost, head = source(statuses, comp, "in", "talker_fast")
        assert received > 0 and lost == 0 and head == 0, (comp, statuses[f"/{comp}"]["values"])


def parent(pid: int) -> int:
    with open(f"/proc/{pid}/stat") as fh:
        return int(fh.read().rsplit(")", 1)[1].split()[1])


def test_through_a_manager(live: LiveSystem) -> None:
    """A manager started with the system applies the plan with the graph it has discovered: the
    same observed outcome, the new node is forked by its launcher, and a re-run is refused as finished (a
    removed node's last status does not make it look alive)."""
    sock = live.manager()
    live.deploy(example("chatter.arch"))
    live.wait_ready()
    script = live.plan_script(["replace", "talker", "-f", example("chatter.arch")])
    statuses = applied(live, live.run_plan(script, "--manager", sock))
    received, lost, head = source(statuses, "listener", "in", "talker_v2")
    assert received > 0 and lost == 0 and head == 0, statuses["/listener"]["values"]
    manager_pid = [p.pid for p in live.procs if p.args[2:3] == ["reconf_ros.tools.manager"]][0]
    launcher_pid = parent(live.pid_of("talker_v2"))      # forked by the manager's launcher
    assert parent(launcher_pid) == manager_pid
    with open(f"/proc/{launcher_pid}/cmdline", "rb") as fh:
        assert b"reconf_ros.tools.launcher" in fh.read()
    again = live.run_plan(script, "--manager", sock, report="again.json")
    assert again.returncode == 1 and "it was applied already" in again.stderr, again.stdout + again.stderr


def test_nodes_use_no_shared_memory(live: LiveSystem) -> None:
    """docs/runtime.md#dds: a live system's processes talk over UDP on the loopback; none maps
    a Fast DDS shared-memory segment (with LOCALHOST discovery every one does)."""
    from pathlib import Path
    live.deploy(example("chatter.arch"))
    live.wait_ready()
    maps = {}
    for pid in sorted(live.pids):
        try:
            maps[pid] = Path(f"/proc/{pid}/maps").read_text()
        except OSError:
            continue
    assert maps, live.pids
    assert [pid for pid, text in maps.items() if "/dev/shm/fastdds" in text] == []


def test_a_batch_stops_at_its_first_failure(live: LiveSystem) -> None:
    """The migration runs steps 3–4 together (the listener's new neighbour's upgrade and the new
    talker's create: docs/executor.md#batches); with the new talker's process exiting at once,
    the run fails at that step, naming why, with the configuration the nodes showed in its
    report, and nothing after the batch is done."""
    arch = live.dir / "migrated.arch"
    arch.write_text(open(example("chatter_migrated.arch")).read().replace(
        'run "reconf-node reconf_ros.demo.chatter:talker_fast"', 'run "python3 -c \'raise SystemExit(3)\'"'))
    live.deploy(example("chatter.arch"))
    live.wait_ready()
    res = live.run_plan(live.plan_script(["migrate", example("chatter.arch"), str(arch)]))
    out = res.stdout + res.stderr
    assert res.returncode == 1, out
    assert "steps 3–4 together:" in out and "exited with status 3 before talker_fast came up" in out, out
    report = live.report()
    assert report["outcome"] == "failed" and report["failed_step"] == 4, report
    assert {t["step"]: t["ok"] for t in report["timings"]}[4] is False
    assert max(t["step"] for t in report["timings"]) == 4            # nothing after the batch
    observed = report["observed"]
    assert observed is not None and report["observed_valid"] is True
    assert "talker_fast" not in observed["components"] and "talker" in observed["components"]


def test_a_halted_step_stops_at_its_next_wait(live: LiveSystem) -> None:
    """A step of a batch another step of which failed stops at its next wait, in its own thread;
    the main thread and the next batch are not stopped (Runtime.halt)."""
    import threading

    from reconf_ros.executor.runtime import Runtime, StepFailed
    rt = Runtime("halt", "", 1.0)
    try:
        seen: list[BaseException] = []

        def step() -> None:
            try:
                rt.wait(lambda: False, 1.5)
            except StepFailed as e:
                seen.append(e)

        worker = threading.Thread(target=step)
        worker.start()
        rt.halt.set()
        worker.join(2.0)
        assert not worker.is_alive() and seen and "another step of its batch failed" in str(seen[0])
        assert rt.wait(lambda: True, 0.1)          # the main thread goes on
        rt.halt.clear()
        worker = threading.Thread(target=step)
        worker.start()
        worker.join(0.3)
        assert worker.is_alive()                   # the next batch's steps are not stopped
        worker.join(3.0)
    finally:
        rt.close()
