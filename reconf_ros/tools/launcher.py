"""A fork server for `reconf-node`: a process with ROS and reconf already imported, and the
architectures it was told about already parsed, that forks each new node instead of starting
a Python from nothing (docs/executor.md#launcher).

Most of a model-driven node's start-up is Python's: imports, then parsing the architecture
(about 0.55 s of 0.85 s on the project's 2-core machine, measured beside a 50-component system).
On a loaded machine that CPU is taken from the running nodes, whose streams then stall. The
manager starts one launcher before it needs it; a `create` step forks from it, and the child
starts at `rclpy.init()`. The child is a process of its own (own PID, own session, its own log),
so a plan, a fault injector or a user can stop it like any other; only its exit status is read
through the launcher, which is its parent. A forked node runs the code the launcher imported
when the manager started: restart the manager after changing reconf or a node's module.

Nothing here initialises ROS: a process that has called `rclpy.init()` has DDS threads and must
not fork.

The client side (`Launcher`, what a manager, an agent or a plan script talks to it with) is
`reconf_ros.executor.launcher`: plan scripts embed it.

Protocol: one JSON object per line on the socket given by `--fd`; each request gets one answer.
    {"warm": ARGV, "cwd": DIR}          parse the architectures ARGV names -> {"ok": true}
    {"start": ARGV, "log": PATH, "cwd": DIR, "env": {...}}  -> {"pid": N} or {"error": TEXT}
        with "hold": true, the child is held before it makes its nodes (below)
    {"release": PID, "names": {...}}    a held child goes on and makes its node, named as given
                                        ("as": its component, "node": its node) -> {"ok": true}
    {"cancel": PID}                     a held child exits, having made none -> {"ok": true}
    {"poll": PID}                       -> {"status": null (running) or the exit status}

A held child (docs/executor.md#held) initialises ROS and waits on a pipe whose other end the
launcher keeps (`HOLD_FD_ENV` names it): a line (the names, JSON), and it makes its nodes; the
end of the pipe (a cancel, or the launcher gone with its client), and it exits having made none.
"""
from __future__ import annotations

import gc
import json
import os
import signal
import socket
import subprocess
import sys
import time
from typing import Any, Iterable, Optional

from ..executor.launcher import PROGRAM
from ..executor.status import HOLD_FD_ENV

__all__ = ["NODE_INTERFACES", "load_types", "serve", "main"]



# The interfaces every node rclpy and reconf make uses (parameters, the log, lifecycle, status):
# each one's type support is a C extension loaded on first use, and the first loads rosidl's
# Python generator too, 35-45 ms of a forked node's start-up when left to it (measured on the
# chatter talker). Loaded once here, every child finds them loaded, as it finds the architecture.
NODE_INTERFACES = (
    "rcl_interfaces/msg/ParameterEvent", "rcl_interfaces/msg/Log", "diagnostic_msgs/msg/DiagnosticArray",
    "lifecycle_msgs/msg/TransitionEvent", "lifecycle_msgs/srv/GetState", "lifecycle_msgs/srv/ChangeState",
    "lifecycle_msgs/srv/GetAvailableStates", "lifecycle_msgs/srv/GetAvailableTransitions",
    "rcl_interfaces/srv/GetParameters", "rcl_interfaces/srv/SetParameters", "rcl_interfaces/srv/ListParameters",
    "rcl_interfaces/srv/DescribeParameters", "rcl_interfaces/srv/GetParameterTypes",
    "rcl_interfaces/srv/SetParametersAtomically", "type_description_interfaces/srv/GetTypeDescription")


def load_types(names: Iterable[str]) -> None:
    """Load the type support of each interface `names` gives (`pkg/msg/Name`, `pkg/srv/Name`); one
    that cannot be loaded is left for the node, which says why."""
    import importlib

    from rclpy.type_support import check_for_type_support
    for name in names:
        try:
            package, kind, short = name.split("/")
            check_for_type_support(getattr(importlib.import_module(f"{package}.{kind}"), short))
        except Exception:
            continue


def _arch_paths(argv: list[str], options: tuple[str, ...] = ("--arch", "--deployed")) -> list[str]:
    return [argv[i + 1] for i, a in enumerate(argv[:-1]) if a in options]


# --- the server (its own process) ---

def _warm(argv: list[str], cwd: str) -> None:
    """Parse the architectures `argv` names and load their messages' type support, so a forked
    child finds them ready (one with errors is left for the child, which reports them in its log)."""
    import click

    from reconf_dsl.diagnostics import DiagnosticError

    from .runner import load_cached, plan_target
    for path in _arch_paths(argv):
        try:
            load_types(m.ros_type for m in load_cached(os.path.join(cwd, path)).messages)
        except (DiagnosticError, OSError):
            pass
    for path in _arch_paths(argv, ("--plan",)):
        try:
            load_types(m.ros_type for m in plan_target(os.path.join(cwd, path))[0].messages)
        except click.UsageError:
            pass


def _child(argv: list[str], log: str, cwd: str, env: dict[str, str], conn: socket.socket,
           others: Iterable[int]) -> None:
    """In the forked child: become a process of its own, then run `reconf-node`. `others`: the
    launcher's ends of the other held children's pipes, closed here (each must end with the
    launcher alone)."""
    code = 1
    try:
        os.close(conn.detach())     # the server's socket is not the node's (and a later close must not hit a reused fd)
        for fd in others:
            os.close(fd)
        os.setsid()
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)    # as in any Python process (SIGPIPE
                                                                    # stays ignored, as Python has it)
        fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)
        os.close(null)
        os.chdir(cwd)
        os.environ.update(env)
        if env.get("PYTHONPATH"):     # as a new interpreter would have it
            sys.path[1:1] = [p for p in env["PYTHONPATH"].split(os.pathsep) if p]
        from .runner import main
        sys.argv = list(argv)
        try:
            main.main(args=argv[1:], prog_name=PROGRAM, standalone_mode=True)
            code = 0
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except BaseException as e:     # the child must never return into the server's loop
        try:
            print(f"reconf launcher: {argv!r} failed: {e!r}", file=sys.stderr)
        except Exception:
            pass
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except Exception:
            pass
        os._exit(code)


def serve(fd: int) -> int:
    """Answer requests on socket `fd` until it closes."""
    import rclpy  # noqa: F401  (imported, never initialised: see the module's docstring)
    import rclpy.executors  # noqa: F401
    import rclpy.lifecycle  # noqa: F401

    from checker.reports.report import render_text  # noqa: F401
    from codegen.ros2 import system_at  # noqa: F401
    from reconf_dsl.loader import load  # noqa: F401

    from ..nodes import adapter, component, generic  # noqa: F401
    from . import runner  # noqa: F401
    load_types(NODE_INTERFACES)
    gc.collect()
    gc.freeze()     # what is imported is kept for good: no collection in a node walks it (docs/executor.md#launcher)
    conn = socket.socket(fileno=fd)
    exited: dict[int, int] = {}
    held: dict[int, int] = {}       # a held child's PID -> the launcher's end of its pipe

    def reap() -> None:
        while True:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return
            exited[pid] = os.waitstatus_to_exitcode(status)
            if pid in held:             # it exited while held
                os.close(held.pop(pid))

    with conn, conn.makefile("rwb") as stream:
        try:
            _answer_each(conn, stream, reap, exited, held)
        except (ConnectionResetError, BrokenPipeError):
            pass        # the client closed with answers unread (a run refused before its first step)
        finally:
            for w in held.values():     # a child still held exits (it made no node)
                os.close(w)
    return 0


def _fork(req: dict[str, Any], stream: Any, conn: socket.socket, held: dict[int, int]) -> int:
    """Fork the child a start request asks for (held, with "hold"): its PID."""
    argv, cwd = [str(a) for a in req["start"]], str(req.get("cwd") or os.getcwd())
    env = {str(k): str(v) for k, v in req.get("env", {}).items()}
    _warm(argv, cwd)
    r, w = os.pipe() if req.get("hold") else (-1, -1)
    if req.get("hold"):
        env[HOLD_FD_ENV] = str(r)
    stream.flush()
    sys.stdout.flush()
    sys.stderr.flush()
    gc.freeze()      # and what `_warm` parsed; frozen objects are not written to by a collection
    pid = os.fork()
    if pid == 0:
        if w >= 0:
            os.close(w)
        _child(argv, str(req["log"]), cwd, env, conn, held.values())
    if w >= 0:
        os.close(r)
        held[pid] = w
    return pid


def _unhold(held: dict[int, int], pid: int, go: bool, names: dict[str, str]) -> dict[str, Any]:
    """Release (`go`, with the `names` its node takes) or cancel the held child `pid`."""
    w = held.pop(pid, None)
    if w is None:
        return {"error": f"pid {pid} is not a held child"}
    try:
        if go:
            os.write(w, json.dumps(names).encode() + b"\n")    # one write, under PIPE_BUF: whole
    except OSError as e:        # it exited while held
        return {"error": f"pid {pid}: {e}"}
    finally:
        os.close(w)
    return {"ok": True}


def _answer_each(conn: socket.socket, stream: Any, reap: Any, exited: dict[int, int], held: dict[int, int]) -> None:
    """Answer each request line of `stream` (on `conn`) until it ends; `reap` fills `exited`."""
    for line in stream:
        reap()
        try:
            req = json.loads(line)
            answer: dict[str, Any]
            if "warm" in req:
                _warm([str(a) for a in req["warm"]], str(req.get("cwd") or os.getcwd()))
                answer = {"ok": True}
            elif "start" in req:
                pid = _fork(req, stream, conn, held)
                exited.pop(pid, None)            # a PID used before: not that child's status
                answer = {"pid": pid}
            elif "release" in req or "cancel" in req:
                answer = _unhold(held, int(req.get("release", req.get("cancel"))), "release" in req,
                                 {str(k): str(v) for k, v in (req.get("names") or {}).items()})
            elif "poll" in req:
                pid = int(req["poll"])
                answer = {"status": exited.get(pid)}
            else:
                answer = {"error": f"unknown request {sorted(req)}"}
        except Exception as e:      # a bad request or an unreadable file: say so, keep serving
            answer = {"error": repr(e)}
        stream.write(json.dumps(answer).encode() + b"\n")
        stream.flush()


def main(argv: Optional[list[str]] = None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m reconf_ros.tools.launcher", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fd", type=int, required=True, help="the socket to serve (inherited from the manager)")
    args = ap.parse_args(argv)
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # the manager ends it by closing the socket
    if sys.path and sys.path[0] in ("", os.getcwd()):
        del sys.path[0]     # `python -m` put the directory here; `reconf-node` imports as an installed script
    return serve(args.fd)


if __name__ == "__main__":
    sys.exit(main())
