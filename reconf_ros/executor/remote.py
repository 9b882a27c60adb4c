"""Processes on other hosts: the client of the per-host agent (`reconf_ros.tools.agent`,
docs/hosts.md#starting-a-component-on-its-host) that starts and stops a component's process on
the host its architecture names.

A hosts file names each host's agent: `{"hosts": {"robot": "10.0.0.2:7411", "station": "local"},
"token_file": "agent.token"}` (the token file's path relative to the hosts file; "local": this
machine, no agent). A connection proves it knows the token, and the agent proves it too
(HMAC-SHA256 of each side's challenge), so nobody else can start processes on a host or pose as
its agent. A host whose agent cannot be reached fails the request with that reason, naming the
host; nothing is taken for started that the agent did not say it started.

Protocol: one JSON object per line. The agent opens with `{"agent": HOST, "challenge": HEX}`;
the client answers `{"proof": HMAC(token, "client:" + challenge), "challenge": HEX}`, the agent
`{"proof": HMAC(token, "agent:" + client's challenge)}`; then requests, each answered once:
    {"op": "start", "argv": [...], "log": "RUN/NAME.log", "env": {...}, "files": {"RUN/F": TEXT}}
        -> {"pid": N, "log": PATH ON THE HOST, "how": TEXT}
    {"op": "poll", "pid": N}                   -> {"status": null (running) or the exit status}
    {"op": "wait", "pid": N, "timeout": S}     -> the same, once it exits or after S s
    {"op": "signal", "pid": N, "signal": SIG}  -> {"status": ...} (only a process it started)
    {"op": "tail", "pid": N, "bytes": B}       -> {"text": the end of its log}
    {"op": "list"}                             -> {"processes": [{"pid", "argv", "log", "status"}]}
An answer with "error" is a refusal, with its reason.
"""
from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
import signal
import socket
import subprocess
import threading
import time
from typing import Any, Optional

AGENT_PORT = 7411            # the agent's default TCP port
LOCAL = "local"              # a hosts file's value for this machine: no agent
MAX_WAIT = 20.0              # s an agent waits for an exit in one request


class HostError(OSError):
    """A host's agent failed a request: the message names the host and why; `host` is its name."""

    def __init__(self, host: str, message: str) -> None:
        super().__init__(message)
        self.host = host

    def __str__(self) -> str:
        return str(self.args[0])


class HostUnreachable(HostError):
    """A host's agent could not be reached, or broke off."""


class HostRefused(HostError):
    """A host's agent answered a request with a refusal (its reason in the message)."""


def proof(token: bytes, role: str, challenge: str) -> str:
    """What a side ("client" or "agent") sends to show it holds `token`."""
    return hmac.new(token, f"{role}:{challenge}".encode(), hashlib.sha256).hexdigest()


def read_hosts(path: str) -> tuple[dict[str, str], bytes]:
    """A hosts file: host -> "ADDRESS:PORT" (or "local"), and the agents' token. Raises
    ValueError with what is wrong, OSError when a file cannot be read."""
    with open(path, encoding="utf-8") as fh:
        doc = json.load(fh)
    hosts = doc.get("hosts") if isinstance(doc, dict) else None
    if not isinstance(hosts, dict) or not all(isinstance(v, str) for v in hosts.values()):
        raise ValueError(f"{path}: not a hosts file (want {{\"hosts\": {{\"NAME\": \"ADDRESS:PORT\"}}, "
                         "\"token_file\": \"FILE\"}})")
    token = b""
    if any(v != LOCAL for v in hosts.values()):
        name = doc.get("token_file")
        if not isinstance(name, str):
            raise ValueError(f"{path}: a hosts file with agents names their token_file")
        with open(os.path.join(os.path.dirname(os.path.abspath(path)), name), "rb") as fh:
            token = fh.read().strip()
        if not token:
            raise ValueError(f"{path}: the token file {name} is empty")
    return {str(k): str(v) for k, v in hosts.items()}, token


class Agent:
    """One host's agent, over one connection made on first use (and again once if it breaks)."""

    def __init__(self, host: str, address: str, token: bytes, timeout: float) -> None:
        self.host, self.address, self.token, self.timeout = host, address, token, timeout
        self.sock: Optional[socket.socket] = None
        self.stream: Any = None
        self.lock = threading.Lock()     # one request at a time on the connection (a batch's steps share it)

    def where(self) -> str:
        return f"host {self.host} ({self.address})"

    def _connect(self) -> None:
        addr, _, port = self.address.rpartition(":")
        try:
            sock = socket.create_connection((addr or self.address, int(port or AGENT_PORT)), timeout=self.timeout)
        except (OSError, ValueError) as e:
            raise HostUnreachable(self.host, f"{self.where()} cannot be reached: {getattr(e, 'strerror', None) or e}") from None
        self.sock, self.stream = sock, sock.makefile("rwb")
        hello = self._read()
        if hello.get("agent") != self.host:
            self.close()
            raise HostUnreachable(self.host, f"{self.where()}: the agent there is host {hello.get('agent')!r}'s")
        mine = secrets.token_hex(16)
        self._write({"proof": proof(self.token, "client", str(hello.get("challenge"))), "challenge": mine})
        answer = self._read()
        if not hmac.compare_digest(str(answer.get("proof", "")), proof(self.token, "agent", mine)):
            self.close()
            raise HostUnreachable(self.host, f"{self.where()}: the agent refused the token, or does not hold it "
                                  f"({answer.get('error', 'no proof')})")

    def _write(self, doc: dict[str, Any]) -> None:
        self.stream.write(json.dumps(doc).encode() + b"\n")
        self.stream.flush()

    def _read(self) -> dict[str, Any]:
        line = self.stream.readline()
        if not line:
            raise ConnectionResetError("the connection closed")
        doc = json.loads(line)
        if not isinstance(doc, dict):
            raise ValueError(f"not an answer: {line[:200]!r}")
        return doc

    def request(self, doc: dict[str, Any], wait: float = 0.0) -> dict[str, Any]:
        """Send one request and return its answer (a refusal raises OSError with the reason);
        `wait`: how much longer than the timeout the agent may take (a wait for an exit)."""
        with self.lock:
            return self._request(doc, wait)

    def _request(self, doc: dict[str, Any], wait: float) -> dict[str, Any]:
        for attempt in (1, 2):
            try:
                if self.sock is None:
                    self._connect()
                assert self.sock is not None
                self.sock.settimeout(self.timeout + wait)
                self._write(doc)
                answer = self._read()
                break
            except HostUnreachable:
                raise
            except (OSError, ValueError) as e:
                self.close()
                if attempt == 2 or doc.get("op") == "start":    # a start is never sent twice
                    raise HostUnreachable(self.host, f"{self.where()} broke off: {getattr(e, 'strerror', None) or e}") from None
        if "error" in answer:
            raise HostRefused(self.host, f"{self.where()} refused: {answer['error']}")
        return answer

    def close(self) -> None:
        for part in (self.stream, self.sock):
            try:
                if part is not None:
                    part.close()
            except OSError:
                pass
        self.sock = self.stream = None


class RemoteProcess:
    """A process an agent started on its host: what an executor needs of a `subprocess.Popen`."""

    def __init__(self, agent: Agent, pid: int, log: str, how: str = "") -> None:
        self.agent, self.pid, self.log, self.how = agent, pid, log, how
        self.returncode: Optional[int] = None

    def poll(self) -> Optional[int]:
        if self.returncode is None:
            status = self.agent.request({"op": "poll", "pid": self.pid}).get("status")
            self.returncode = None if status is None else int(status)
        return self.returncode

    def wait(self, timeout: Optional[float] = None) -> int:
        end = None if timeout is None else time.monotonic() + timeout
        while self.returncode is None:
            left = MAX_WAIT if end is None else end - time.monotonic()
            if left <= 0:
                raise subprocess.TimeoutExpired(f"pid {self.pid} on {self.agent.where()}", timeout or 0.0)
            chunk = min(left, MAX_WAIT)
            status = self.agent.request({"op": "wait", "pid": self.pid, "timeout": chunk}, wait=chunk).get("status")
            self.returncode = None if status is None else int(status)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.returncode is None:
            status = self.agent.request({"op": "signal", "pid": self.pid, "signal": int(sig)}).get("status")
            self.returncode = None if status is None else int(status)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)

    def tail(self, size: int = 2000) -> str:
        """The end of its log, read on its host."""
        return str(self.agent.request({"op": "tail", "pid": self.pid, "bytes": size}).get("text", ""))


class Hosts:
    """The agents a hosts file names (`read_hosts`), each reached on first use. A host the file
    does not name fails, naming the host and the file: a component is never started elsewhere
    than where its architecture places it."""

    def __init__(self, path: str, timeout: float) -> None:
        self.path, self.timeout = path, timeout
        self.where, self.token = read_hosts(path)
        self.agents: dict[str, Agent] = {}

    def agent(self, host: Optional[str]) -> Optional[Agent]:
        """The agent of `host`; None for this machine (no host, or the file's "local")."""
        if not host:
            return None
        address = self.where.get(host)
        if address is None:
            raise HostError(host, f"host {host} is not in the hosts file {self.path} (it names "
                          f"{', '.join(sorted(self.where)) or 'no host'})")
        if address == LOCAL:
            return None
        return self.agents.setdefault(host, Agent(host, address, self.token, self.timeout))

    def start(self, agent: Agent, argv: list[str], log: str, env: dict[str, str],
              files: Optional[dict[str, str]] = None) -> RemoteProcess:
        """Start `argv` on the agent's host: its log `log` (a relative name) in the agent's log
        directory, `env` added to the agent's environment (with this process's ROS domain, which
        the nodes must share), `files` (relative name -> text) written there first, and an
        argument naming one of them given its path there."""
        env = {"ROS_DOMAIN_ID": os.environ.get("ROS_DOMAIN_ID", "0"), **env}
        answer = agent.request({"op": "start", "argv": argv, "log": log, "env": env, "files": files or {}})
        return RemoteProcess(agent, int(answer["pid"]), str(answer["log"]), str(answer.get("how", "")))

    def close(self) -> None:
        for agent in self.agents.values():
            agent.close()
