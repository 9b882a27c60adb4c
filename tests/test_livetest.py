"""The live-test harness's own guarantees, without ROS: a live system's domain is one no running
process uses, and every process it started, even one whose PID no test read, ends with it."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from reconf_ros.tools.livetest import TAG, LiveSystem, alive, domain_id, environs


def test_a_domain_a_running_process_uses_is_not_given(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RECONF_LIVE_DOMAINS", "201-203")
    holders = [subprocess.Popen(["sleep", "30"], env=dict(os.environ, ROS_DOMAIN_ID=str(d))) for d in (201, 202)]
    try:
        assert {domain_id() for _ in range(6)} == {203}
    finally:
        for p in holders:
            p.kill()
            p.wait()
    assert {domain_id() for _ in range(6)} == {201, 202, 203}


def test_a_process_no_test_knew_the_pid_of_ends_with_its_system(tmp_path: Path,
                                                                 capfd: pytest.CaptureFixture[str]) -> None:
    live = LiveSystem(tmp_path)
    # a grandchild in a session of its own whose parent exits at once: as a launcher's child is
    spawn = ("import subprocess\n"
             "print(subprocess.Popen(['sleep', '60'], start_new_session=True, stdout=subprocess.DEVNULL,"
             " stderr=subprocess.DEVNULL).pid)")
    pid = int(subprocess.run([sys.executable, "-c", spawn], env=live.env, capture_output=True, text=True,
                             timeout=30).stdout)
    known = live.start(["sleep", "60"], "known.log")       # ended by its PID: not a stray
    try:
        assert environs(TAG)[pid] == live.tag == environs(TAG)[known.pid]
        live.stop()
        end = time.monotonic() + 5
        while alive(pid) and time.monotonic() < end:
            time.sleep(0.05)
        assert not alive(pid)
        err = capfd.readouterr().err
        assert f"livetest: ended process {pid} (sleep 60), left running in domain {live.domain}" in err
        assert known.poll() is not None and f"process {known.pid} " not in err
    finally:
        if alive(pid):
            os.kill(pid, signal.SIGKILL)
