"""The per-host agent (reconf_ros.tools.agent) and its client in the executor
(reconf_ros.executor.remote), on this machine over TCP with plain programs: a start gives the
process's PID and its log on the host, its exit status is the real one, only a client holding
the token is served, only the agent's own processes can be signalled, and a host that cannot be
reached fails with that reason, naming the host."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator

import pytest

from reconf_ros.executor.remote import Agent, Hosts, HostUnreachable, RemoteProcess, read_hosts


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def agent(tmp_path: Path) -> Iterator[tuple[str, bytes, Path]]:
    """An agent of host `robot` on 127.0.0.1: its address, token and log directory."""
    token = b"s3cret-token"
    (tmp_path / "agent.token").write_bytes(token + b"\n")
    port = _free_port()
    ready = tmp_path / "ready"
    proc = subprocess.Popen([sys.executable, "-m", "reconf_ros.tools.agent", "--host", "robot", "--listen",
                             f"127.0.0.1:{port}", "--token-file", str(tmp_path / "agent.token"), "--log-dir",
                             str(tmp_path / "logs"), "--no-launcher", "--ready-file", str(ready)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 20
        while not ready.exists() and proc.poll() is None and time.monotonic() < end:
            time.sleep(0.05)
        assert ready.exists(), "the agent did not start"
        yield f"127.0.0.1:{port}", token, tmp_path / "logs"
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def _start(client: Agent, argv: list[str], **extra: object) -> RemoteProcess:
    answer = client.request({"op": "start", "argv": argv, "log": "run1/x.log", "env": {"GREETING": "hi"}, **extra})
    return RemoteProcess(client, int(answer["pid"]), str(answer["log"]))


def test_a_process_started_on_its_host(agent: tuple[str, bytes, Path]) -> None:
    address, token, logs = agent
    client = Agent("robot", address, token, timeout=5)
    proc = _start(client, ["sh", "-c", "echo $GREETING from $(cat run1/in.txt); exit 3"],
                  files={"run1/in.txt": "a shipped file"})
    assert proc.wait(timeout=10) == 3
    assert proc.log == str(logs / "run1" / "x.log")
    assert proc.tail() == "hi from a shipped file\n"
    listed = client.request({"op": "list"})["processes"]
    assert [(p["pid"], p["status"]) for p in listed] == [(proc.pid, 3)]


def test_stopping_a_process_and_its_status(agent: tuple[str, bytes, Path]) -> None:
    address, token, _ = agent
    client = Agent("robot", address, token, timeout=5)
    proc = _start(client, ["sleep", "30"])
    assert proc.poll() is None
    with pytest.raises(subprocess.TimeoutExpired):
        proc.wait(timeout=0.3)
    proc.terminate()
    assert proc.wait(timeout=10) == -signal.SIGTERM


def test_only_its_own_processes_are_signalled(agent: tuple[str, bytes, Path]) -> None:
    address, token, _ = agent
    client = Agent("robot", address, token, timeout=5)
    with pytest.raises(OSError, match=f"pid {os.getpid()} is not a process this agent started"):
        client.request({"op": "signal", "pid": os.getpid(), "signal": signal.SIGKILL})
    with pytest.raises(OSError, match="is not found on host robot"):
        client.request({"op": "start", "argv": ["no-such-program-here"], "log": "run1/y.log"})
    with pytest.raises(OSError, match="not a relative file name"):
        client.request({"op": "start", "argv": ["true"], "log": "../../etc/passwd"})


def test_a_client_without_the_token_is_refused(agent: tuple[str, bytes, Path]) -> None:
    address, _, _ = agent
    with pytest.raises(HostUnreachable, match="host robot .*refused the token"):
        Agent("robot", address, b"wrong", timeout=5).request({"op": "list"})
    with pytest.raises(HostUnreachable, match="the agent there is host 'robot'"):
        Agent("station", address, b"wrong", timeout=5).request({"op": "list"})


def test_a_host_that_cannot_be_reached_says_so() -> None:
    port = _free_port()     # nothing listens there
    with pytest.raises(HostUnreachable, match=f"host robot \\(127.0.0.1:{port}\\) cannot be reached"):
        Agent("robot", f"127.0.0.1:{port}", b"t", timeout=2).request({"op": "list"})


def test_a_hosts_file(tmp_path: Path) -> None:
    (tmp_path / "t").write_text("tok\n")
    (tmp_path / "hosts.json").write_text(json.dumps({"hosts": {"a": "10.0.0.1:7411", "b": "local"},
                                                     "token_file": "t"}))
    assert read_hosts(str(tmp_path / "hosts.json")) == ({"a": "10.0.0.1:7411", "b": "local"}, b"tok")
    (tmp_path / "bad.json").write_text(json.dumps({"hosts": {"a": "10.0.0.1:7411"}}))
    with pytest.raises(ValueError, match="names their token_file"):
        read_hosts(str(tmp_path / "bad.json"))


def test_the_hosts_of_a_hosts_file(agent: tuple[str, bytes, Path], tmp_path: Path) -> None:
    address, token, logs = agent
    (tmp_path / "t").write_bytes(token)
    (tmp_path / "hosts.json").write_text(json.dumps({"hosts": {"robot": address, "station": "local"},
                                                     "token_file": "t"}))
    hosts = Hosts(str(tmp_path / "hosts.json"), timeout=5)
    assert hosts.agent(None) is None and hosts.agent("station") is None       # this machine
    with pytest.raises(OSError, match="host arm is not in the hosts file .*hosts.json \\(it names robot, station\\)"):
        hosts.agent("arm")
    robot = hosts.agent("robot")
    assert robot is not None
    proc = hosts.start(robot, ["sh", "-c", "echo $ROS_DOMAIN_ID $MARK"], "plan1/n.log", {"MARK": "m"})
    assert proc.wait(timeout=10) == 0
    assert proc.tail().split() == [os.environ.get("ROS_DOMAIN_ID", "0"), "m"]
    hosts.close()
    # the log read by its agent from the command line, as a report names it (host, pid)
    out = subprocess.run([sys.executable, "-m", "reconf_ros.tools.agent", "--hosts", str(tmp_path / "hosts.json"),
                          "--tail", f"robot:{proc.pid}"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0 and out.stdout.split() == [os.environ.get("ROS_DOMAIN_ID", "0"), "m"], out.stderr


ROOT = Path(__file__).resolve().parents[1]
CHATTER_HOSTS = ROOT / "examples" / "chatter_hosts.arch"


def _up_doc() -> dict[str, object]:
    from checker.planning.bringup import plan_up
    from checker.reports.plan_document import plan_document
    from reconf_dsl.loader import load
    system = load([str(CHATTER_HOSTS)])
    plan = plan_up(system)
    return plan_document("bring chatter_hosts up", system, plan, {"python_engine": "valid"}, model=True)


def test_a_plan_refuses_a_hosts_file_it_cannot_read(tmp_path: Path) -> None:
    """`--hosts` is read when the options are: a missing or wrong file is a usage error (exit 2)
    naming it, before anything is applied, from a plan script and from `reconf up` alike."""
    from codegen.ros2 import render_plan_script
    script = tmp_path / "up.py"
    script.write_text(render_plan_script(_up_doc()))
    (tmp_path / "agentless.json").write_text(json.dumps({"hosts": {"robot": "127.0.0.1:7411"}}))
    for name, says in (("missing.json", "missing.json: No such file or directory"),
                       ("agentless.json", "a hosts file with agents names their token_file")):
        res = subprocess.run([sys.executable, str(script), "--dry-run", "--hosts", str(tmp_path / name)],
                             capture_output=True, text=True, timeout=60)
        assert res.returncode == 2 and f"error: --hosts: {tmp_path}" in res.stderr and says in res.stderr, res.stderr
    res = subprocess.run([str(Path(sys.executable).with_name("reconf")), "up", str(CHATTER_HOSTS), "--no-alloy",
                          "--yes", "--hosts", str(tmp_path / "missing.json")], capture_output=True, text=True,
                         timeout=120, cwd=tmp_path)
    assert res.returncode == 2 and "Error: --hosts:" in res.stderr and "Traceback" not in res.stderr, res.stderr


def test_a_create_on_a_host_the_hosts_file_does_not_name_fails_naming_it(tmp_path: Path) -> None:
    """The executor asks the hosts file for the component's host before anything else: one it does
    not name fails, naming the host and the file, and nothing is started here instead."""
    import argparse

    from reconf_ros.executor.context import Context
    from reconf_ros.executor.processes import launch, on_agent
    from reconf_ros.executor.remote import HostError
    (tmp_path / "t").write_text("tok\n")
    hosts = tmp_path / "hosts.json"
    hosts.write_text(json.dumps({"hosts": {"station": "local", "arm": "127.0.0.1:1"}, "token_file": "t"}))
    args = argparse.Namespace(hosts=str(hosts), timeout=2.0, log_dir=str(tmp_path / "logs"))
    ctx = Context(_up_doc(), args, sys.stdout, sys.stderr)
    assert on_agent(ctx, "talker") and not on_agent(ctx, "listener")     # robot: not in the file; station: here
    with pytest.raises(HostError, match=f"host robot is not in the hosts file {hosts} \\(it names arm, station\\)") \
            as failed:
        launch(ctx, "talker")
    assert failed.value.host == "robot"
    assert not (tmp_path / "logs").exists()
    assert Context(_up_doc(), argparse.Namespace(timeout=2.0, log_dir=""), sys.stdout, sys.stderr).hosts is None
