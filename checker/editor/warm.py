"""The warm analyzer `reconf check` talks to, as `dmypy` does: a running `reconf lsp` or
`reconf daemon` listens on a local socket, and `reconf check` sends it its arguments, current
directory and start-up time instead of starting Python and a JVM of its own. The server runs
the same command in its process (the JVM already started, the evaluation module parsed, files
it has read kept by content) and sends back what it printed and its exit code; the client prints
them as they are. No server, a server of another installation, or one that does not answer in
time: the client runs cold, as before.

The socket is `RECONF_SOCKET`, else `reconf-<uid>/warm.sock` under `XDG_RUNTIME_DIR` (or the
temporary directory), in a directory only its user can enter. `RECONF_NO_WARM=1` keeps a command
cold. One request at a time: a command runs under `workspace.LOCK`, in the client's directory,
with the client's RECONF_* variables."""
from __future__ import annotations

import json
import os
import socket
import struct
import tempfile
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Optional

import checker

NO_WARM_ENV = "RECONF_NO_WARM"
SOCKET_ENV = "RECONF_SOCKET"
PASSED_ENV = ("NO_COLOR", "FORCE_COLOR", "COLUMNS", "TERM")   # besides every RECONF_* variable
CONNECT_TIMEOUT = 0.5        # seconds to reach a server that is there
ANSWER_TIMEOUT = 3600.0      # seconds for a command to run there
INSTALL = os.path.realpath(os.path.dirname(checker.__file__))

Runner = Callable[[list[str]], tuple[str, str, int]]   # argv -> stdout, stderr, exit code


def socket_path() -> str:
    given = os.environ.get(SOCKET_ENV)
    if given:
        return given
    base = os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()
    return os.path.join(base, f"reconf-{os.getuid()}", "warm.sock")


def wanted() -> bool:
    return os.environ.get(NO_WARM_ENV, "") in ("", "0") and not _serving.is_set()


# ---------------------------------------------------------------------------------- framing

def _send(sock: socket.socket, doc: dict[str, Any]) -> None:
    data = json.dumps(doc).encode("utf-8")
    sock.sendall(struct.pack(">I", len(data)) + data)


def _receive(sock: socket.socket) -> Optional[dict[str, Any]]:
    head = _exactly(sock, 4)
    if head is None:
        return None
    body = _exactly(sock, struct.unpack(">I", head)[0])
    return None if body is None else json.loads(body.decode("utf-8"))  # type: ignore[no-any-return]


def _exactly(sock: socket.socket, n: int) -> Optional[bytes]:
    chunks, left = [], n
    while left:
        chunk = sock.recv(min(left, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


# ---------------------------------------------------------------------------------- the client

@dataclass(frozen=True)
class Answer:
    stdout: str
    stderr: str
    exit: int
    by: str          # "reconf lsp, pid 4242"


def ask(argv: list[str], age: float, tty: bool) -> Optional[Answer]:
    """Run `reconf ARGV` in the warm server, or None (run cold) when there is none to run it."""
    path = socket_path()
    if not os.path.exists(path):
        return None
    env = {k: v for k, v in os.environ.items() if k.startswith("RECONF_") or k in PASSED_ENV}
    if tty and "NO_COLOR" not in env:
        env.setdefault("FORCE_COLOR", "1")
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(CONNECT_TIMEOUT)
            sock.connect(path)
            sock.settimeout(ANSWER_TIMEOUT)
            _send(sock, {"argv": argv, "cwd": os.getcwd(), "env": env, "age": age, "install": INSTALL})
            reply = _receive(sock)
    except OSError:
        return None
    if not reply or "exit" not in reply:
        return None
    return Answer(reply["stdout"], reply["stderr"], int(reply["exit"]), reply.get("by", "a warm analyzer"))


def stop(timeout: float = 10.0) -> Optional[int]:
    """Ask the server to end; its pid, or None when none answered."""
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(timeout)
            sock.connect(socket_path())
            _send(sock, {"stop": True, "install": INSTALL})
            reply = _receive(sock)
    except OSError:
        return None
    return int(reply["pid"]) if reply and "pid" in reply else None


def status() -> Optional[dict[str, Any]]:
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(CONNECT_TIMEOUT * 4)
            sock.connect(socket_path())
            _send(sock, {"status": True, "install": INSTALL})
            return _receive(sock)
    except OSError:
        return None


# ---------------------------------------------------------------------------------- the server

_serving = threading.Event()      # set in a process that serves: its own commands never ask
_state: dict[str, Any] = {"label": "", "cache": None, "age": None}


def shared_parse() -> Optional[Callable[[str, str], Any]]:
    """While a warm server runs a command: its parse of files by content; else None."""
    cache = _state["cache"]
    return cache.parse if _serving.is_set() and cache is not None else None


def start_up() -> Optional[tuple[float, str]]:
    """While a warm server runs a command: the client's start-up and who served it."""
    age = _state["age"]
    return None if age is None else (age, _state["label"])


class Server:
    """Listens on the socket and runs each request with `runner`, one at a time."""

    def __init__(self, runner: Runner, label: str, on_stop: Optional[Callable[[], None]] = None) -> None:
        self.runner, self.label, self.on_stop = runner, f"{label}, pid {os.getpid()}", on_stop
        self.path = socket_path()
        self.started = time.time()
        self.served = 0
        self._sock: Optional[socket.socket] = None

    def bind(self) -> bool:
        """Take the socket; False when another live server holds it."""
        from checker.editor.workspace import ParseCache  # here for start-up time: a client never loads it
        os.makedirs(os.path.dirname(self.path), mode=0o700, exist_ok=True)
        if os.path.exists(self.path):
            if status() is not None:
                return False
            os.unlink(self.path)      # left by a server that died
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.bind(self.path)
        os.chmod(self.path, 0o600)
        sock.listen(8)
        self._sock = sock
        _serving.set()
        _state["label"], _state["cache"] = self.label, ParseCache(64)
        return True

    def serve_forever(self) -> None:
        assert self._sock is not None
        while True:
            try:
                conn, _ = self._sock.accept()
            except OSError:
                return
            with conn:
                if not self._handle(conn):
                    self.close()
                    return

    def start(self) -> threading.Thread:
        thread = threading.Thread(target=self.serve_forever, name="reconf-warm", daemon=True)
        thread.start()
        return thread

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
            try:
                os.unlink(self.path)
            except OSError:
                pass
        if self.on_stop is not None:
            self.on_stop()

    def _handle(self, conn: socket.socket) -> bool:
        """Answer one request; False when it asks the server to stop."""
        conn.settimeout(30)
        try:
            request = _receive(conn)
        except (OSError, ValueError):
            return True
        conn.settimeout(None)
        if not request or request.get("install") != INSTALL:
            _send(conn, {"refused": f"another installation of reconf ({INSTALL})"})
            return True
        if request.get("stop"):
            _send(conn, {"pid": os.getpid()})
            return False
        if request.get("status"):
            _send(conn, {"pid": os.getpid(), "by": self.label, "since": self.started, "served": self.served})
            return True
        out, err, code = self._run(request)
        self.served += 1
        try:
            _send(conn, {"stdout": out, "stderr": err, "exit": code, "by": self.label})
        except OSError:
            pass        # the client went away (interrupted)
        return True

    def _run(self, request: dict[str, Any]) -> tuple[str, str, int]:
        from checker.editor.workspace import LOCK  # here for start-up time: a client never loads it
        with LOCK, _client(request["cwd"], request.get("env", {}), float(request.get("age", 0.0))):
            return self.runner(list(request["argv"]))


@contextmanager
def _client(cwd: str, env: dict[str, str], age: float) -> Iterator[None]:
    """The client's directory and RECONF_* variables (and its colours), for one command."""
    here = os.getcwd()
    before = {k: v for k, v in os.environ.items() if k.startswith("RECONF_") or k in PASSED_ENV}
    for k in before:
        del os.environ[k]
    os.environ.update(env)
    _state["age"] = age
    os.chdir(cwd)
    try:
        yield
    finally:
        os.chdir(here)
        _state["age"] = None
        for k in [k for k in os.environ if k.startswith("RECONF_") or k in PASSED_ENV]:
            del os.environ[k]
        os.environ.update(before)
