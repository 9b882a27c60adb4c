"""The client side of the launcher (`reconf_ros.tools.launcher`, a fork server with ROS and reconf
imported): start it, ask it to fork a `reconf-node`, read its children's exit statuses
(docs/executor.md#launcher). Standard library only: plan scripts embed it and start a launcher
of their own where this environment has `reconf-node` (`processes.own_launcher`)."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from typing import Any, Optional

__all__ = ["Launcher", "Launched", "launchable", "PROGRAM"]

PROGRAM = "reconf-node"


def launchable(argv: list[str]) -> bool:
    """Whether the launcher can start `argv`: this environment's own `reconf-node`."""
    return bool(argv) and os.path.basename(argv[0]) == PROGRAM and \
        os.path.dirname(os.path.abspath(argv[0])) == os.path.dirname(os.path.abspath(sys.executable))


class Launched:
    """A node the launcher forked: what an executor needs of a `subprocess.Popen`."""

    def __init__(self, launcher: "Launcher", pid: int) -> None:
        self.launcher, self.pid = launcher, pid
        self.returncode: Optional[int] = None

    def poll(self) -> Optional[int]:
        if self.returncode is None:
            self.returncode = self.launcher.status(self.pid)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            try:
                os.kill(self.pid, sig)
            except ProcessLookupError:
                pass

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)

    def wait(self, timeout: Optional[float] = None) -> int:
        end = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if end is not None and time.monotonic() >= end:
                raise subprocess.TimeoutExpired(f"pid {self.pid}", timeout or 0.0)
            time.sleep(0.02)
        assert self.returncode is not None
        return self.returncode


class Launcher:
    """Starts the launcher process and talks to it (from any thread: one request at a time). If it
    is gone, `available` turns false and callers start processes the ordinary way."""

    def __init__(self, timeout: float = 30.0) -> None:
        mine, theirs = socket.socketpair()
        self.proc = subprocess.Popen([sys.executable, "-m", "reconf_ros.tools.launcher", "--fd", str(theirs.fileno())],
                                     pass_fds=[theirs.fileno()], stdin=subprocess.DEVNULL,
                                     preexec_fn=_die_with_parent)
        theirs.close()
        mine.settimeout(timeout)
        self.sock = mine
        self.stream = mine.makefile("rwb")
        self.available = True
        self.statuses: dict[int, int] = {}
        self.unread = 0             # answers to warm requests, read before the next answer
        self.lock = threading.RLock()

    def can_start(self, argv: list[str]) -> bool:
        return self.available and launchable(argv)

    def send(self, req: dict[str, Any]) -> None:
        if not self.available:
            raise OSError("the launcher has stopped")
        try:
            self.stream.write(json.dumps(req).encode() + b"\n")
            self.stream.flush()
        except OSError:
            self.available = False
            raise

    def request(self, req: dict[str, Any]) -> dict[str, Any]:
        with self.lock:
            return self._request(req)

    def _request(self, req: dict[str, Any]) -> dict[str, Any]:
        self.send(req)
        try:
            while self.unread:
                self.stream.readline()
                self.unread -= 1
            line = self.stream.readline()
        except BaseException:       # an answer left unread would be taken for the next one's
            self.available = False
            raise
        if not line:
            self.available = False
            raise OSError(f"the launcher exited (status {self.proc.poll()})")
        answer: dict[str, Any] = json.loads(line)
        if "error" in answer:
            raise OSError(f"the launcher: {answer['error']}")
        return answer

    def warm(self, argv: list[str], cwd: str = "") -> None:
        """Ask the launcher to parse what `argv` reads; the answer is not waited for."""
        with self.lock:
            self.send({"warm": argv, "cwd": cwd or os.getcwd()})
            self.unread += 1

    def start(self, argv: list[str], log: str, cwd: str = "", env: Optional[dict[str, str]] = None,
              hold: bool = False) -> Launched:
        """Fork `argv` with `env` added to the launcher's environment; with `hold`, the child
        initialises ROS and waits for `release` before it makes its nodes (or exits at `cancel`,
        or when the launcher ends, having made none: docs/executor.md#held)."""
        answer = self.request({"start": argv, "log": os.path.abspath(log), "cwd": cwd or os.getcwd(),
                               "env": env or {}, "hold": hold})
        return Launched(self, int(answer["pid"]))

    def release(self, pid: int, names: Optional[dict[str, str]] = None) -> None:
        """Let the held child `pid` make its node, under `names` if given (its component "as", its
        node "node", as `reconf-node --as --node` name them). Raises OSError if it is not held
        (it exited)."""
        self.request({"release": pid, "names": names or {}})

    def cancel(self, pid: int) -> None:
        """End the held child `pid`: it exits having made no node."""
        self.request({"cancel": pid})

    def status(self, pid: int) -> Optional[int]:
        """The exit status of a child that exited, else None (also when the launcher is gone and
        the PID still runs)."""
        if pid in self.statuses:
            return self.statuses[pid]
        try:
            status = self.request({"poll": pid})["status"]
        except OSError:
            try:
                os.kill(pid, 0)
                return None
            except ProcessLookupError:
                status = -1         # gone, status unknown: its parent was the launcher
        if status is not None:
            self.statuses[pid] = int(status)
        return None if status is None else int(status)

    def close(self, wait: bool = True) -> None:
        """Close the socket: the launcher ends (its children stay). With `wait`, wait for it; a
        process about to exit need not (0.15-0.2 s of a plan script's end), as the launcher ends
        with its parent (PR_SET_PDEATHSIG) if it has not yet."""
        try:
            self.stream.close()
            self.sock.close()
        finally:
            if wait:
                try:
                    self.proc.wait(timeout=3)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()


def _die_with_parent() -> None:
    """The launcher ends with the process that started it, a manager, an agent or a plan script (its
    children do not: they are the system's nodes)."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except OSError:
        pass
