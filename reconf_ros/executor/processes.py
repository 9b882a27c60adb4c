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
import subprocess
import sys
from typing import Any

from .context import Context
from .runtime import StepFailed


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


def list_started(ctx: Context, stop: bool) -> None:
    """Name every process this run started (pid, state, log); with `stop`, end the ones still
    running (SIGTERM, then SIGKILL after 3 s)."""
    if not ctx.started:
        return
    ctx.warn("Processes this run started:")
    for c, info in sorted(ctx.started.items()):
        alive = info.proc.poll() is None
        if alive and stop:
            info.proc.terminate()
            try:
                info.proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                info.proc.kill()
            ctx.warn(f"  {c}: pid {info.pid} stopped (--stop-started), log {info.log}")
        else:
            state = "running" if alive else f"exited with status {info.proc.returncode}"
            ctx.warn(f"  {c}: pid {info.pid} {state}, log {info.log}")
