"""`python -m reconf_ros.tools.agent --host NAME`: the per-host agent that starts and stops the
components of its host for the plans that create and remove them (docs/hosts.md#starting-a-component-on-its-host).

One agent runs on each host, started by its init system (a systemd unit, as robot_upstart
makes one, with the host's ROS environment), listening on the host's address. A plan's executor
on any host connects to it (`reconf_ros.executor.remote`: protocol and authentication), and the
agent starts each process in a session of its own with its log in the agent's log directory,
is its parent (so it knows its exit status exactly), signals only processes it started, and
serves the ends of their logs. `reconf-node` commands are forked from a launcher that has ROS
and reconf imported (docs/executor.md#launcher), as the manager's are.

    python -m reconf_ros.tools.agent --host robot --listen 10.0.0.2:7411 --token-file /etc/reconf/agent.token \\
        [--log-dir /var/log/reconf] [--no-launcher]
    python -m reconf_ros.tools.agent --hosts hosts.json --tail robot:PID [--bytes N]    # the end of a log there
"""
from __future__ import annotations

import argparse
import hmac
import json
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from typing import Any, Optional

from ..executor.launcher import Launcher, launchable
from ..executor.remote import AGENT_PORT, MAX_WAIT, Hosts, RemoteProcess, proof

__all__ = ["Agent", "main"]

SAFE_PATH = re.compile(r"^(?!/)(?!.*(^|/)\.\.(/|$))[\w@%+=:,./-]+$")    # relative, no `..`


@dataclass
class Child:
    pid: int
    argv: list[str]
    log: str
    proc: Any               # subprocess.Popen, or the launcher's handle


class Agent:
    """The agent's state: its host, token, log directory, launcher and the processes it started."""

    def __init__(self, host: str, token: bytes, log_dir: str, launcher: bool = True) -> None:
        self.host, self.token, self.log_dir = host, token, os.path.abspath(log_dir)
        self.children: dict[int, Child] = {}
        self.lock = threading.Lock()
        self.launcher: Optional[Launcher] = Launcher() if launcher else None

    def path(self, rel: str) -> str:
        """A file under the log directory, from a relative name a client gave."""
        if not SAFE_PATH.match(rel):
            raise ValueError(f"not a relative file name under the agent's log directory: {rel!r}")
        full = os.path.join(self.log_dir, rel)
        os.makedirs(os.path.dirname(full), exist_ok=True)
        return full

    def start(self, req: dict[str, Any]) -> dict[str, Any]:
        """Start a process: write the files it reads, then fork or spawn it, its output to its log."""
        argv = [str(a) for a in req["argv"]]
        files = {rel: self.path(rel) for rel in req.get("files", {})}
        for rel, text in req.get("files", {}).items():
            with open(files[rel], "w", encoding="utf-8") as fh:
                fh.write(str(text))
        argv = [files.get(a, a) for a in argv]     # a file shipped with the request, by its name here
        # the program as this host has it: the executor names it as the architecture's run line does
        exe = shutil.which(argv[0]) or shutil.which(argv[0], path=os.path.dirname(sys.executable))
        if exe is None:
            raise ValueError(f"{argv[0]!r} is not found on host {self.host}")
        argv[0] = exe
        log = self.path(str(req["log"]))
        env = {str(k): str(v) for k, v in req.get("env", {}).items()}
        how = ""
        with self.lock:
            if self.launcher is not None and self.launcher.can_start(argv):
                try:
                    proc: Any = self.launcher.start(argv, log, cwd=self.log_dir, env=env)
                    how = " (forked by the agent's launcher)"
                except OSError:
                    proc = None
            else:
                proc = None
            if proc is None:
                with open(log, "ab") as fh:
                    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=fh, stderr=subprocess.STDOUT,
                                            start_new_session=True, cwd=self.log_dir, env={**os.environ, **env})
            self.children[proc.pid] = Child(proc.pid, argv, log, proc)
        return {"pid": proc.pid, "log": log, "how": how}

    def child(self, req: dict[str, Any]) -> Child:
        pid = int(req["pid"])
        with self.lock:
            found = self.children.get(pid)
        if found is None:
            raise ValueError(f"pid {pid} is not a process this agent started")
        return found

    def status(self, c: Child) -> Optional[int]:
        with self.lock:
            return c.proc.poll()

    def wait(self, c: Child, seconds: float) -> Optional[int]:
        end = time.monotonic() + min(max(seconds, 0.0), MAX_WAIT)
        while (status := self.status(c)) is None and time.monotonic() < end:
            time.sleep(0.02)
        return status

    def answer(self, req: dict[str, Any]) -> dict[str, Any]:
        op = req.get("op")
        if op == "start":
            return self.start(req)
        if op == "list":
            with self.lock:
                kids = list(self.children.values())
            return {"processes": [{"pid": c.pid, "argv": c.argv, "log": c.log, "status": self.status(c)}
                                  for c in kids]}
        c = self.child(req)
        if op == "poll":
            return {"status": self.status(c)}
        if op == "wait":
            return {"status": self.wait(c, float(req.get("timeout", 0)))}
        if op == "signal":
            if self.status(c) is None:
                os.kill(c.pid, int(req["signal"]))
            return {"status": self.wait(c, 0.1)}
        if op == "tail":
            size = int(req.get("bytes", 2000))
            with open(c.log, "rb") as fh:
                fh.seek(max(0, os.fstat(fh.fileno()).st_size - size))
                return {"text": fh.read().decode(errors="replace")}
        raise ValueError(f"unknown request {op!r}")

    def serve(self, conn: socket.socket) -> None:
        """One client: the challenges both ways, then its requests until it closes."""
        with conn, conn.makefile("rwb") as stream:
            def send(doc: dict[str, Any]) -> None:
                stream.write(json.dumps(doc).encode() + b"\n")
                stream.flush()
            try:
                challenge = secrets.token_hex(16)
                send({"agent": self.host, "challenge": challenge})
                hello = json.loads(stream.readline() or b"{}")
                if not hmac.compare_digest(str(hello.get("proof", "")), proof(self.token, "client", challenge)):
                    send({"error": "the client's proof does not match this agent's token"})
                    return
                send({"proof": proof(self.token, "agent", str(hello.get("challenge", "")))})
                for line in stream:
                    try:
                        answer = self.answer(json.loads(line))
                    except (ValueError, KeyError, TypeError, OSError) as e:
                        answer = {"error": str(e)}
                    send(answer)
            except (OSError, ValueError):
                return      # the client went away


def listen(address: str) -> socket.socket:
    addr, _, port = address.rpartition(":")
    sock = socket.create_server((addr or address, int(port or AGENT_PORT)), reuse_port=False)
    return sock


def tail(hosts_file: str, where: str, size: int) -> int:
    """Print the end of the log of process PID on HOST (`where` is HOST:PID), read by its agent."""
    host, _, pid = where.rpartition(":")
    try:
        hosts = Hosts(hosts_file, timeout=10.0)
        agent = hosts.agent(host)
        if agent is None:
            raise ValueError(f"host {host} is this machine in {hosts_file}: read its log here")
        print(RemoteProcess(agent, int(pid), "").tail(size), end="")
        hosts.close()
        return 0
    except (OSError, ValueError) as e:
        print(f"reconf agent: {e}", file=sys.stderr)
        return 2


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m reconf_ros.tools.agent", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--host", help="this host's name, as the architecture writes it")
    ap.add_argument("--listen", default=f"0.0.0.0:{AGENT_PORT}", metavar="ADDRESS:PORT")
    ap.add_argument("--token-file", help="the secret its clients must prove they hold")
    ap.add_argument("--log-dir", default="reconf-agent-logs", help="where the processes' logs go")
    ap.add_argument("--ready-file", default="", help=argparse.SUPPRESS)
    ap.add_argument("--no-launcher", action="store_true", help="start reconf-node like any other command")
    ap.add_argument("--hosts", help="a hosts file: with --tail, the agents to ask")
    ap.add_argument("--tail", metavar="HOST:PID", help="print the end of the log of PID, which HOST's agent started")
    ap.add_argument("--bytes", type=int, default=4000, help="with --tail: how much (default 4000)")
    args = ap.parse_args(argv)
    if args.tail:
        if not args.hosts:
            ap.error("--tail needs --hosts FILE")
        return tail(args.hosts, args.tail, args.bytes)
    if not args.host or not args.token_file:
        ap.error("an agent needs --host and --token-file")
    try:
        with open(args.token_file, "rb") as fh:
            token = fh.read().strip()
        if not token:
            raise ValueError(f"{args.token_file} is empty")
        server = listen(args.listen)
    except (OSError, ValueError) as e:
        print(f"reconf agent: {e}", file=sys.stderr)
        return 2
    os.makedirs(args.log_dir, exist_ok=True)
    agent = Agent(args.host, token, args.log_dir, launcher=not args.no_launcher)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    print(f"reconf agent of host {args.host}: listening on {args.listen}, logs in {agent.log_dir}", flush=True)
    if args.ready_file:
        with open(args.ready_file, "w") as fh:
            fh.write(str(os.getpid()))
    with server:
        while True:
            conn, _ = server.accept()
            threading.Thread(target=agent.serve, args=(conn,), daemon=True).start()


if __name__ == "__main__":
    sys.exit(main())
