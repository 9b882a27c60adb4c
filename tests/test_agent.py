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
