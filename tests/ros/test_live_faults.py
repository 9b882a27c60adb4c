"""Faults during a plan: the executor stops, says what it observes, never claims success."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

from reconf_ros.tools.livetest import LiveSystem

from .conftest import example


def deploy_chatter(live: LiveSystem, strategy: str = "default") -> object:
    arch = example("chatter.arch")
    live.deploy(arch)
    live.wait_ready()
    return live.plan_script(["replace", "talker", "-f", arch, "--strategy", strategy])


def test_node_killed_after_create(live: LiveSystem) -> None:
    script = deploy_chatter(live)
    first = live.run_plan(script, "--to-step", "1", report="first.json")
    assert first.returncode == 0 and "stopped after step 1 as asked" in first.stdout, first.stderr
    os.kill(live.pid_of("talker_v2", "first.json"), signal.SIGKILL)
    res = live.run_plan(script, "--from-step", "2", report="second.json")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "steps done" not in res.stdout
    assert "talker_v2 is not running, the plan expects it present" in res.stderr
    report = live.report("second.json")
    assert report["outcome"] == "stale" and "talker_v2" not in report["observed"]["components"]
    assert report["observed"]["components"] == ["listener", "talker"]


def test_node_killed_after_attach(live: LiveSystem) -> None:
    """talker_v2 dies as soon as its output is attached: the run must not end in success."""
    script = deploy_chatter(live)
    proc = subprocess.Popen([sys.executable, str(script), "--yes", "--log-dir", str(live.dir / "logs"),
                             "--report", str(live.dir / "report.json"), "--wire-timeout", "3"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=live.env, cwd=live.dir)
    live.pids.add(proc.pid)
    out = []
    pid = None
    assert proc.stdout is not None
    for line in proc.stdout:
        out.append(line)
        if "started talker_v2: pid" in line:
            pid = int(re.search(r"pid (\d+)", line).group(1))  # type: ignore[union-attr]
            live.pids.add(pid)
        if line.strip().startswith("done") and any("attach talker_v2.out" in x for x in out[-3:]):
            assert pid is not None, "".join(out)
            os.kill(pid, signal.SIGKILL)
    err = proc.stderr.read() if proc.stderr else ""
    assert proc.wait(timeout=60) == 1, "".join(out) + err
    text = "".join(out)
    assert "no monitor saw" not in text
    report = live.report()
    assert report["outcome"] in ("failed", "violated"), report["outcome"]
    assert "talker_v2" not in report["observed"]["components"], report["observed"]
    if report["outcome"] == "failed":   # stopped before detaching the old talker: still valid
        assert "talker_v2" in err and "FAILED" in err and "reconf recover" in err
    else:                               # it had detached it: the wire shows the loss
        assert "not met" in err or "violation" in err


def test_stale_plan_is_refused(live: LiveSystem) -> None:
    script = deploy_chatter(live, "paper")
    # the listener is degraded by hand: the plan's first state no longer matches
    ros = subprocess.run([sys.executable, "-c", (
        "import rclpy, sys\n"
        "from rclpy.parameter import Parameter\n"
        "from rcl_interfaces.srv import SetParameters\n"
        "rclpy.init(); n = rclpy.create_node('operator')\n"
        "c = n.create_client(SetParameters, '/listener/set_parameters'); c.wait_for_service(10)\n"
        "r = SetParameters.Request(); r.parameters = [Parameter('reconf.mode.listen', Parameter.Type.STRING, "
        "'degraded').to_parameter_msg()]\n"
        "f = c.call_async(r); rclpy.spin_until_future_complete(n, f, timeout_sec=10)\n"
        "sys.exit(0 if f.result().results[0].successful else 1)\n")], env=live.env, capture_output=True, text=True,
        timeout=60)
    assert ros.returncode == 0, ros.stderr
    res = live.run_plan(script)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "refusing to apply" in res.stderr
    assert "listener.listen is degraded, the plan expects normal" in res.stderr
    assert "It matches the state after step 1; resume with --from-step 2" in res.stderr
    assert live.report()["outcome"] == "stale"
    assert "started" not in res.stdout


def test_rerun_of_a_finished_plan_is_refused(live: LiveSystem) -> None:
    script = deploy_chatter(live)
    first = live.run_plan(script, report="first.json")
    assert first.returncode == 0, first.stdout + first.stderr
    time.sleep(0.5)
    res = live.run_plan(script, report="again.json")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "the plan's last: it was applied already" in res.stderr
    assert "started talker_v2" not in res.stdout


def test_recover_after_a_failure(live: LiveSystem) -> None:
    """A node killed mid-plan; `reconf recover` plans from what was observed to the target."""
    script = deploy_chatter(live)
    first = live.run_plan(script, "--to-step", "2", report="first.json")
    assert first.returncode == 0, first.stdout + first.stderr
    os.kill(live.pid_of("talker_v2", "first.json"), signal.SIGKILL)
    failed = live.run_plan(script, "--from-step", "3", report="failed.json")
    assert failed.returncode == 1, failed.stdout + failed.stderr
    out = live.dir / "recover.py"
    res = subprocess.run([os.path.join(os.path.dirname(sys.executable), "reconf"), "recover",
                          str(live.dir / "failed.json"), "--no-alloy", "-o", str(out)],
                         capture_output=True, text=True, env=live.env)
    assert res.returncode == 0, res.stderr
    assert "create talker_v2" in res.stderr and "remove talker" in res.stderr
    done = live.run_plan(out, report="recovered.json")
    assert done.returncode == 0, done.stdout + done.stderr
    report = live.report("recovered.json")
    assert report["observed"]["components"] == ["listener", "talker_v2"]
    assert live.violations(live.settle_status(["listener", "talker_v2"])) == {}
