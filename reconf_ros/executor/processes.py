"""The processes a plan starts and stops: a component's command line (its `run`, or a
model-driven `reconf-node` of the architecture the plan reaches), with its node's name and
namespace; started in a session of its own with its own log, forked by a manager's launcher
where it can be (docs/executor.md#launcher)."""
from __future__ import annotations

import hashlib
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from typing import Any, Iterable, Optional

from .context import Context
from .runtime import StepFailed
from .status import CREATED_ENV


def command(ctx: Context, comp: str) -> list[str]:
    """The component's run line, or, when it has none, a model-driven node of the architecture
    the plan reaches (`reconf-node --plan`); with the node's name and namespace. A component
    that is not a reconf node (its `node` block) is started by its adapter, `reconf-node --plan`
    too, which runs the run line itself (docs/adapter.md)."""
    run, names = ctx.runs.get(comp), ctx.names
    adapted = "node" in ctx.model.comps.get(comp, {})
    if adapted and not run:
        raise StepFailed(f"{comp} is a node reconf does not build (its `node` block) and has no run line: "
                         "reconf cannot start it")
    argv = shlex.split(run) if run and not adapted else ["reconf-node", "--plan", plan_path(ctx), comp]
    exe = shutil.which(argv[0]) or shutil.which(argv[0], path=os.path.dirname(sys.executable))
    if exe is None:
        raise StepFailed(f"{argv[0]!r} (the run command of {comp}) is not found")
    argv[0] = exe
    named = comp in names.placed and os.path.basename(exe) == "reconf-node"
    if named:       # the component it is, under the node's own name (rcl's remap rules refuse "__")
        argv[1:1] = ["--as", names.declared(comp), "--node", names.placed[comp]]
    remaps = ([f"__ns:={ctx.rt.namespace}"] if ctx.rt.namespace else []) + \
        ([f"__node:={names.placed[comp]}"] if comp in names.placed and not named else [])
    if remaps:
        argv += ["--ros-args"] if "--ros-args" not in argv else []
        for r in remaps:
            argv += ["-r", r]
    return argv


def plan_path(ctx: Context) -> str:
    """The plan document in the log directory, for the nodes that read it; named by its
    content, so a log directory shared by several plans gives each node its own plan."""
    text = json.dumps(ctx.doc, sort_keys=True)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = os.path.abspath(os.path.join(ctx.log_dir, f"plan-{digest}.json"))
    if not os.path.exists(path):
        os.makedirs(ctx.log_dir, exist_ok=True)
        tmp = f"{path}.tmp{os.getpid()}"
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    return path


def start(ctx: Context, argv: list[str], log: str, env: dict[str, str]) -> tuple[Any, str]:
    """Start a node's process, in a session of its own with its own log and `env` added:
    forked by the launcher when there is one and it can, else the ordinary way. Returns the
    process and how it was started, for the step's line."""
    if ctx.launcher is not None and ctx.launcher.can_start(argv):
        try:
            return ctx.launcher.start(argv, log, env=env), " (forked by the launcher)"
        except OSError as e:
            ctx.say(f"      the launcher could not start it ({e}); starting it the ordinary way")
    with open(log, "ab") as fh:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True, env={**os.environ, **env})
    return proc, ""


def warm(ctx: Context, first: int, last: int) -> None:
    """Let the launcher parse what the steps' new nodes will read, while the live system is
    checked."""
    if ctx.launcher is None:
        return
    for step in ctx.steps[first - 1:last]:
        if step.action != "create":
            continue
        try:
            argv = command(ctx, step.component)
        except StepFailed:
            continue                    # the step itself will say so
        if ctx.launcher.can_start(argv):
            try:
                ctx.launcher.warm(argv)
            except OSError:
                return                  # the launcher is gone: creates start the ordinary way


def wait_exit(proc: Any, seconds: float) -> int:
    """Wait for a process to exit: `seconds`, then SIGTERM and 2 s, then SIGKILL. Its status."""
    try:
        proc.wait(timeout=seconds)
    except subprocess.TimeoutExpired:
        proc.terminate()
        try:
            proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return int(proc.returncode)


def _stop(proc: Any) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=3)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=3)


def list_started(ctx: Context, stop: bool, present: Optional[Iterable[str]] = None) -> None:
    """Name every process this run started (pid, state, log); with `stop`, end the ones still
    running (SIGTERM, then SIGKILL after 3 s); and, whatever `stop`, those whose component is not
    in the `present` ones observed: never activated, they are in no configuration and would
    only stand in the way of a run or a recovery that starts them again."""
    if not ctx.started:
        return
    keep = None if present is None else set(present)
    ctx.warn("Processes this run started:")
    for c, info in sorted(ctx.started.items()):
        alive = info.proc.poll() is None
        if alive and (stop or (keep is not None and c not in keep)):
            _stop(info.proc)
            info.ended = info.proc.returncode
            why = "--stop-started" if stop else "never active: in no configuration"
            ctx.warn(f"  {c}: pid {info.pid} stopped ({why}), log {info.log}")
        else:
            state = "running" if alive else f"exited with status {info.proc.returncode}"
            ctx.warn(f"  {c}: pid {info.pid} {state}, log {info.log}")


def _process(pid: Optional[int], mark: str) -> Optional[bool]:
    """Whether `pid` is a live process of this host whose environment carries the creation
    `mark` (True), another process or a zombie (False), or none (None)."""
    if not pid:
        return None
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            if fh.read().rsplit(")", 1)[1].split()[0] == "Z":
                return None
        with open(f"/proc/{pid}/environ", "rb") as fh:
            env = fh.read().split(b"\0")
    except (OSError, IndexError):
        return None
    return f"{CREATED_ENV}={mark}".encode() in env


def _wait_gone(pid: int, mark: str, seconds: float) -> bool:
    end = time.monotonic() + seconds
    while _process(pid, mark):
        if time.monotonic() >= end:
            return False
        time.sleep(0.05)
    return True


def end_orphan(ctx: Context, orphan: dict[str, Any]) -> str:
    """End a node a plan started that is in no configuration (docs/executor.md#recovering-from-the-live-system):
    down its lifecycle to finalized (a reconf node then exits), its process signalled if it does
    not exit (only a process of this host that carries the node's creation mark). What was done."""
    fqn, pid, mark = orphan["node"], orphan.get("pid"), orphan.get("created", "")
    transition = ctx.rt.Transition
    try:
        lc = ctx.rt.lifecycle(fqn) if fqn in ctx.rt.nodes() else "gone"
    except StepFailed:
        lc = "unresponsive"
    if lc == "active":
        raise StepFailed(f"the orphan {fqn} is active now: plan the recovery again")
    if lc in ("unconfigured", "inactive"):
        tid = transition.TRANSITION_UNCONFIGURED_SHUTDOWN if lc == "unconfigured" else \
            transition.TRANSITION_INACTIVE_SHUTDOWN
        try:
            ctx.rt.transition(fqn, tid, "shutdown")
        except StepFailed as e:
            lc = f"{lc}, shutdown refused ({e})"
    ctx.rt.forget(fqn)
    if pid is None or _wait_gone(pid, mark, ctx.args.timeout):
        return f"{lc} → finalized, exited" if lc in ("unconfigured", "inactive") else f"{lc}"
    for sig in (signal.SIGTERM, signal.SIGKILL):
        if _process(pid, mark):
            os.kill(pid, sig)
            if _wait_gone(pid, mark, 3.0):
                return f"{lc}; did not exit, ended by {sig.name}"
    raise StepFailed(f"the orphan {fqn} (pid {pid}) did not exit")


def end_orphans(ctx: Context) -> None:
    """End every orphan a recovery's plan lists, before its first step."""
    for orphan in ctx.orphans:
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        how = end_orphan(ctx, orphan)
        ctx.say(f"ended the orphan {orphan['node']} (pid {orphan.get('pid') or 'unknown'}): {how}")
