"""The configuration manager of paper 001 §5.2: a long-lived node that applies plans.

A plan script started on its own is a new DDS participant: before it may trust the graph it
waits for discovery (`reconf_ros.executor.runtime.Runtime.settled`), and every service it calls is new to it. The
manager runs beside the system, keeps one `Runtime` (graph, statuses, service clients) alive,
and applies the plans its clients send (`plan.py --manager`) with that runtime, so a plan
starts from a graph already discovered; it forks new `reconf-node`s from a launcher
(`launcher.py`) that has ROS and reconf imported. Clients reach it through a Unix socket on this host;
one plan runs at a time. Protocol and reasoning: docs/executor.md#manager.

    python -m reconf_ros.tools.manager [--socket PATH] [--namespace NS]
"""
from __future__ import annotations

import argparse
import json
import os
import select
import socket
import sys
import time
from typing import Any, Callable, Optional

from ..executor.context import Interrupts
from ..executor.launcher import Launcher
from ..executor.run import Executor
from ..executor.runtime import Runtime
from ..executor.script import manager_socket, parse
from ..executor.status import tool_node
from ..executor.steps import EXIT_FAILED, EXIT_USAGE
from ..nodes.kept_executor import KeptExecutor

__all__ = ["main", "serve"]

GRAPH_POLL = 0.25   # s between looks at the graph while idle (the settle rule needs its history)


class Stream:
    """A file-like object that sends each write to the client as one JSON line."""

    def __init__(self, out: Any, name: str) -> None:
        self.out, self.name = out, name

    def write(self, text: str) -> int:
        if text:
            self.out.write(json.dumps({"stream": self.name, "text": text}).encode() + b"\n")
        return len(text)

    def flush(self) -> None:
        self.out.flush()


def stop_requests(conn: socket.socket, stream: Any) -> Callable[[], str]:
    """What the client forwards while its plan runs: a line {"stop": SIGNAL} when the plan script
    is interrupted (docs/executor.md#interrupted); read without waiting."""
    def poll() -> str:
        try:
            ready, _, _ = select.select([conn], [], [], 0)
            line = stream.readline() if ready else b""
            return str(json.loads(line).get("stop", "")) if line.strip() else ""
        except (OSError, ValueError, AttributeError):
            return ""
    return poll


def handle(rt: Runtime, conn: socket.socket, launcher: Optional[Launcher] = None,
           interrupts: Optional[Interrupts] = None) -> None:
    """Read one request (a plan document and the script's arguments), apply it, send the exit."""
    interrupts = interrupts or Interrupts()
    with conn, conn.makefile("rwb") as stream:
        out, err = Stream(stream, "out"), Stream(stream, "err")
        try:
            line = stream.readline()
            interrupts.poll = stop_requests(conn, stream)
            code = run(rt, line, out, err, launcher, interrupts)
            stream.write(json.dumps({"exit": code}).encode() + b"\n")
            stream.flush()
        except OSError:     # the client went away; the run itself has finished or failed
            pass
        finally:
            interrupts.forget_requests()


def run(rt: Runtime, line: bytes, out: Stream, err: Stream, launcher: Optional[Launcher] = None,
        interrupts: Optional[Interrupts] = None) -> int:
    try:
        request = json.loads(line or b"{}")
        doc, argv = request["doc"], [str(a) for a in request["argv"]]
        args = parse(doc, argv)
    except (ValueError, KeyError, TypeError) as e:
        err.write(f"the manager received a request it cannot read: {e}\n")
        return EXIT_USAGE
    except SystemExit:
        err.write(f"the manager cannot use these arguments: {' '.join(argv)}\n")
        return EXIT_USAGE
    here = os.getcwd()
    os.chdir(args.cwd or here)
    try:
        return Executor(doc, args, out=out, err=err, runtime=rt, launcher=launcher,
                        interrupts=interrupts).apply(args.from_step)
    except Exception as e:      # keep serving; the client hears what went wrong
        err.write(f"the manager failed while applying the plan: {e!r}\n")
        return EXIT_FAILED
    finally:
        os.chdir(here)


def serve(path: str, namespace: str = "", timeout: float = 5.0, ready: Optional[str] = None,
          launch: bool = True) -> int:
    os.makedirs(os.path.dirname(path) or ".", mode=0o700, exist_ok=True)
    if os.path.exists(path):
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.connect(path)
        except OSError:
            os.unlink(path)        # left by a manager that died
        else:
            probe.close()
            print(f"a reconf manager is already listening at {path}", file=sys.stderr)
            return EXIT_USAGE
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    os.chmod(path, 0o600)
    server.listen(4)
    server.settimeout(0.0)
    launcher = Launcher() if launch else None
    interrupts = Interrupts()   # SIGINT, SIGTERM: a plan running stops at its step's end, then the manager ends
    interrupts.install()
    rt = Runtime("manager", namespace, timeout, node_name=tool_node("manager"), executor=KeptExecutor)
    print(f"reconf manager: listening at {path} (node {rt.node.get_fully_qualified_name()}, pid {os.getpid()})",
          flush=True)
    if ready:
        with open(ready, "w", encoding="utf-8") as fh:
            fh.write(path)
    try:
        _loop(rt, server, launcher, interrupts)
    except KeyboardInterrupt:   # a second signal while idle
        pass
    finally:
        if launcher is not None:
            launcher.close()
        server.close()
        try:
            os.unlink(path)
        except OSError:
            pass
        rt.close()
    return 0


def _loop(rt: Runtime, server: socket.socket, launcher: Optional[Launcher], interrupts: Interrupts) -> None:
    """Serve clients one at a time until a signal comes (the plan it interrupts ends first)."""
    looked = 0.0
    while not interrupts.signals:
        rt.spin(0.05)
        if time.monotonic() - looked >= GRAPH_POLL:
            rt.graph()
            looked = time.monotonic()
        try:
            conn, _ = server.accept()
        except (BlockingIOError, TimeoutError):
            continue
        conn.settimeout(None)
        handle(rt, conn, launcher, interrupts)
    print(f"reconf manager: {interrupts.by}: stopping", flush=True)


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m reconf_ros.tools.manager", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--socket", default="", help="where to listen (default: one per ROS domain, under $XDG_RUNTIME_DIR/reconf or /tmp/reconf-UID/reconf)")
    ap.add_argument("--namespace", default="", help="namespace of the components' nodes")
    ap.add_argument("--timeout", type=float, default=5.0, metavar="S", help="per service call, in seconds")
    ap.add_argument("--no-launcher", action="store_true",
                    help="start each new reconf-node as a new Python process instead of forking it from a "
                         "launcher that has ROS and reconf imported (docs/executor.md#launcher)")
    ap.add_argument("--ready-file", default="", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    return serve(args.socket or manager_socket(args.namespace), args.namespace, args.timeout, args.ready_file or None,
                 launch=not args.no_launcher)


if __name__ == "__main__":
    sys.exit(main())
