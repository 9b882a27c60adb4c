"""The processes a plan starts and stops: a component's command line (its `run`, or a
model-driven `reconf-node` of the architecture the plan reaches), with its node's name and
namespace; started in a session of its own with its own log, forked by a launcher where it can
be (a manager's, or the plan script's own: docs/executor.md#launcher); or, with a hosts file (`--hosts`), on the host the
component's architecture names, by that host's agent (`remote`, docs/hosts.md)."""
from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from typing import Any, Iterable, Optional

from .context import Context, Held, Started
from .launcher import PROGRAM, Launcher, launchable
from .remote import LOCAL, Agent, HostError, HostRefused, RemoteProcess
from .runtime import StepFailed
from .status import CREATED_ENV, tool_node
from .steps import plural


def command(ctx: Context, comp: str, remote: bool = False) -> list[str]:
    """The component's run line, or, when it has none, a model-driven node of the architecture
    the plan reaches (`reconf-node --plan`); with the node's name and namespace. A component
    that is not a reconf node (its `node` block) is started by its adapter, `reconf-node --plan`
    too, which runs the run line itself (docs/adapter.md). `remote`: for an agent on another host,
    which finds the program there; the plan file is then named by `remote_plan` (shipped with the start)."""
    run, names = ctx.runs.get(comp), ctx.names
    adapted = "node" in ctx.model.comps.get(comp, {})
    if adapted and not run:
        raise StepFailed(f"{comp} is a node reconf does not build (its `node` block) and has no run line: "
                         "reconf cannot start it")
    plan = remote_plan(ctx)[0] if remote else ""
    argv = shlex.split(run) if run and not adapted else ["reconf-node", "--plan", plan or plan_path(ctx), comp]
    exe = argv[0] if remote else shutil.which(argv[0]) or shutil.which(argv[0], path=os.path.dirname(sys.executable))
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


def _plan_text(ctx: Context) -> tuple[str, str]:
    """The plan document as the nodes read it, and its file's name, named by its content (so a
    log directory shared by several plans gives each node its own plan)."""
    text = json.dumps(ctx.doc, sort_keys=True)
    return f"plan-{hashlib.sha256(text.encode()).hexdigest()[:16]}.json", text


def plan_path(ctx: Context) -> str:
    """The plan document in the log directory, for the nodes that read it."""
    name, text = _plan_text(ctx)
    path = os.path.abspath(os.path.join(ctx.log_dir, name))
    if not os.path.exists(path):
        os.makedirs(ctx.log_dir, exist_ok=True)
        tmp = f"{path}.tmp{os.getpid()}"
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    return path


def run_name(ctx: Context) -> str:
    """This run's directory under an agent's log directory: the last part of the log directory,
    in the characters an agent accepts in a file name."""
    return re.sub(r"[^\w.-]", "_", os.path.basename(os.path.abspath(ctx.log_dir))).lstrip(".") or "run"


def remote_plan(ctx: Context) -> tuple[str, str]:
    """The plan file's name under an agent's log directory, and its text."""
    name, text = _plan_text(ctx)
    return f"{run_name(ctx)}/{name}", text


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


def host_agent(ctx: Context, comp: str) -> Optional[Agent]:
    """The agent that starts and stops `comp`'s process: None where the process runs on this
    machine (no hosts file, no `host` for the component, or the file's "local"). Raises
    `HostError` (an OSError naming the host) when the hosts file does not name its host: a
    component is never started elsewhere than where its architecture places it."""
    host = ctx.model.comps.get(comp, {}).get("host")
    if ctx.hosts is None or not host:
        return None
    agent: Optional[Agent] = ctx.hosts.agent(host)
    return agent


def on_agent(ctx: Context, comp: str) -> bool:
    """Whether `comp`'s process is an agent's (or its host is not in the hosts file)."""
    host = ctx.model.comps.get(comp, {}).get("host")
    return ctx.hosts is not None and bool(host) and ctx.hosts.where.get(str(host)) != LOCAL


def launch(ctx: Context, comp: str) -> Started:
    """Start `comp`'s process where it runs, with its creation mark in its environment: here
    (a held one released, or `start`), or by its host's agent, which is sent the plan file when
    the node reads it and adds the plan's ROS domain (`Hosts.start`). Returns it (its `how`: how
    it was started, for the step's line). Raises StepFailed, or a `HostError` naming the host
    when its agent cannot be reached or refuses."""
    with _LAUNCHING:
        return _launch(ctx, comp)


# the creates of a batch start their processes one at a time: the plan file, the launcher's
# socket and an agent's connection are each written by one thread (docs/executor.md#batches)
_LAUNCHING = threading.Lock()


def _launch(ctx: Context, comp: str) -> Started:
    agent = host_agent(ctx, comp)
    env, fqn = {CREATED_ENV: ctx.names.created_mark(comp)}, ctx.names.fqn(comp)
    if agent is None or ctx.hosts is None:
        argv = command(ctx, comp)
        log = os.path.join(ctx.log_dir, f"{ctx.names.node_name(comp)}.log")
        held = _release(ctx, comp, argv, log)
        if held is not None:
            ahead = time.monotonic() - held.at
            return Started(held.proc.pid, held.log, shlex.join(argv), fqn, held.proc, held=ahead,
                           how=f" (forked by the launcher {ahead:.2f} s before, held until now)")
        os.makedirs(ctx.log_dir, exist_ok=True)
        proc, how = start(ctx, argv, log, env)
        return Started(proc.pid, log, shlex.join(argv), fqn, proc, how=how)
    argv = command(ctx, comp, remote=True)
    plan, text = remote_plan(ctx)
    files = {plan: text} if plan in argv else {}
    remote = ctx.hosts.start(agent, argv, f"{run_name(ctx)}/{ctx.names.node_name(comp)}.log", env, files)
    return Started(remote.pid, remote.log, shlex.join(argv), fqn, remote, host=agent.host,
                   how=f" on host {agent.host}{remote.how}")


def wait_removed(ctx: Context, comp: str, pid: Optional[int], seconds: float) -> str:
    """After `comp`'s node is finalized, wait up to `seconds` for its process to exit (then
    SIGTERM, then SIGKILL: `wait_exit`): a process this run started, wherever it runs, or, for
    a component on an agent's host, the process its status named (`pid`), by that agent. What
    was seen, for the step's line ("" for a process of this machine another run started, as
    before). Raises `HostError` naming the host when its agent cannot be reached."""
    info = ctx.started.get(comp)
    if info is not None:
        info.ended = wait_exit(info.proc, seconds)
        return f"its process (pid {info.pid}{_on(info.host)}) exited with status {info.ended}" if info.host else ""
    agent = host_agent(ctx, comp)
    if agent is None or pid is None:
        return ""
    try:
        status = wait_exit(RemoteProcess(agent, pid, ""), seconds)
    except HostRefused as e:    # not a process the agent started (one started by hand there)
        return f"its process (pid {pid}) is not host {agent.host}'s agent's, which says: {e}"
    return f"its process (pid {pid} on host {agent.host}) exited with status {status}"


def _end_remote(ctx: Context, fqn: str, comp: str, pid: int) -> Optional[str]:
    """An orphan's process on an agent's host, waited for (and ended) by that agent: its exit
    status as words; None where the component runs on this machine. Raises StepFailed when the
    agent cannot be reached or did not start it (its end is then not known)."""
    try:
        agent = host_agent(ctx, comp)
        if agent is None:
            return None
        return f"exited with status {wait_exit(RemoteProcess(agent, pid, ''), ctx.args.timeout)} on host {agent.host}"
    except HostError as e:
        ctx.failed_host = e.host
        raise StepFailed(f"the orphan {fqn} (pid {pid}): {e}") from None


def _on(host: str) -> str:
    return f" on host {host}" if host else ""


def own_launcher(ctx: Context, first: int, last: int) -> None:
    """Start a launcher of this run's own (a plan script's, not a manager's) when steps `first`..
    `last` create a node this environment's `reconf-node` runs, and `--no-launcher` is not
    given: its imports (about 0.5 s) overlap the wait for discovery, and each create forks from
    it instead of starting a Python from nothing. The run closes it (its children stay)."""
    if ctx.launcher is not None or getattr(ctx.args, "no_launcher", True):
        return
    here = os.path.join(os.path.dirname(sys.executable), PROGRAM)
    for step in ctx.steps[first - 1:last]:
        if step.action != "create" or on_agent(ctx, step.component):
            continue
        run = ctx.runs.get(step.component)       # as `command` reads it (before ROS: no namespace yet)
        program = shlex.split(run)[0] if run and "node" not in ctx.model.comps.get(step.component, {}) else PROGRAM
        if os.path.basename(program) == PROGRAM and os.path.exists(here) and launchable([here]):
            try:
                ctx.launcher = Launcher()
            except OSError as e:
                ctx.say(f"no launcher ({e}): new nodes start the ordinary way")
            return


def forkable(ctx: Context, first: int, last: int) -> list[tuple[str, list[str]]]:
    """The creates of steps `first`..`last` the launcher will start, with their commands: a
    process of this machine whose command is this environment's `reconf-node` (none without a
    launcher)."""
    if ctx.launcher is None:
        return []
    out = []
    for step in ctx.steps[first - 1:last]:
        if step.action != "create" or on_agent(ctx, step.component):
            continue
        try:
            argv = command(ctx, step.component)
        except StepFailed:
            continue                    # the step itself will say so
        if ctx.launcher.can_start(argv):
            out.append((step.component, argv))
    return out


def warm(ctx: Context, forks: list[tuple[str, list[str]]]) -> None:
    """Let the launcher parse what the new nodes `forks` (`forkable`) will read, while the live
    system is checked."""
    for _, argv in forks:
        try:
            ctx.launcher.warm(argv)
        except OSError:
            return                      # the launcher is gone: creates start the ordinary way


def hold(ctx: Context, forks: list[tuple[str, list[str]]]) -> None:
    """Fork ahead, held, the processes of the creates `forks` (`forkable`; not with `--no-hold`):
    in a thread of its own, while the live system is checked. A held process initialises ROS and
    keeps a hidden node of reconf's own, so that by its create its DDS participant has been
    discovered, and it makes its node only when released, under the name its create chose (a
    new version's: docs/executor.md#held)."""
    if not forks or getattr(ctx.args, "no_hold", True):
        return
    os.makedirs(ctx.log_dir, exist_ok=True)
    ctx.holding = threading.Thread(target=_fork_held, args=(ctx, forks), name="hold", daemon=True)
    ctx.holding.start()


HELD_UP_WITHIN = 2.0     # s the next held process waits at most for the last one to be up


def _fork_held(ctx: Context, todo: list[tuple[str, list[str]]]) -> None:
    """Fork each one in turn, the next once the last is up (its hidden node in the graph), or
    released already (its step came first), or after HELD_UP_WITHIN s: one process starting ROS
    at a time, as at the steps, not a burst that starves the running nodes."""
    for comp, argv in todo:
        log = os.path.join(ctx.log_dir, f"{ctx.names.node_name(comp)}.log")
        try:
            proc = ctx.launcher.start(argv, log, env={CREATED_ENV: ctx.names.created_mark(comp)}, hold=True)
        except OSError:
            return                      # the launcher is gone: creates start the ordinary way
        ctx.held[comp] = Held(proc, argv, log, time.monotonic())
        up, end = tool_node("held", proc.pid), time.monotonic() + HELD_UP_WITHIN
        while not ctx.hold_stop.is_set() and time.monotonic() < end and comp in ctx.held and \
                up not in (n for n, _ in ctx.rt.node.get_node_names_and_namespaces()):
            time.sleep(0.02)
        if ctx.hold_stop.is_set():
            return


def _release(ctx: Context, comp: str, argv: list[str], log: str) -> Optional[Held]:
    """The held process of `comp`, released, if there is one still held for this command: the
    same, or the same but for the names the create chose (`--as X --node N`), which it then
    takes; its log renamed to `log` (the node's name)."""
    holding = ctx.holding
    if holding is not None:           # until it has forked this one (or stopped)
        ctx.rt.wait(lambda: comp in ctx.held or not holding.is_alive(), ctx.rt.left())
    held = ctx.held.pop(comp, None)
    if held is None:
        return None
    names, rest = {}, argv
    if argv[1:2] == ["--as"] and argv[3:4] == ["--node"]:
        names, rest = {"as": argv[2], "node": argv[4]}, argv[:1] + argv[5:]
    try:
        if held.argv != rest or held.proc.poll() is not None:
            ctx.launcher.cancel(held.proc.pid)
            return None
        ctx.launcher.release(held.proc.pid, names)
    except OSError:
        return None                     # it exited while held, or the launcher is gone
    if held.log != log:
        try:
            os.replace(held.log, log)
            held.log = log
        except OSError:
            pass                        # it writes on where it was forked to write
    return held


def end_held(ctx: Context) -> None:
    """Cancel the processes still held at the end of a run (their creates were not reached, or
    adopted a node already there): each exits having made no node."""
    if ctx.holding is not None:
        ctx.hold_stop.set()
        ctx.holding.join(10.0)
        ctx.holding = None
    if ctx.held:
        ended = plural(len(ctx.held), "node process", "node processes")
        ctx.say(f"      {ended} forked ahead and never released: ended ({', '.join(sorted(ctx.held))})")
    for held in ctx.held.values():
        try:
            ctx.launcher.cancel(held.proc.pid)
        except OSError:
            pass                        # gone with the launcher: it exits all the same
    ctx.held.clear()


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
    """Name every process this run started (pid, host, state, log); with `stop`, end the ones
    still running (SIGTERM, then SIGKILL after 3 s); and, whatever `stop`, those whose component
    is not in the `present` ones observed: never activated, they are in no configuration and
    would only stand in the way of a run or a recovery that starts them again. A process whose
    host's agent cannot be reached is named with that reason, its state unknown."""
    if not ctx.started:
        return
    keep = None if present is None else set(present)
    ctx.warn("Processes this run started:")
    for c, info in sorted(ctx.started.items()):
        where = f"pid {info.pid}{_on(info.host)}"
        try:
            alive = info.proc.poll() is None
            if alive and (stop or (keep is not None and c not in keep)):
                _stop(info.proc)
                info.ended = info.proc.returncode
                why = "--stop-started" if stop else "never active: in no configuration"
                ctx.warn(f"  {c}: {where} stopped ({why}), log {info.log}")
                continue
        except HostError as e:
            ctx.warn(f"  {c}: {where}, state not known ({e}), log {info.log}")
            continue
        state = "running" if alive else f"exited with status {info.proc.returncode}"
        ctx.warn(f"  {c}: {where} {state}, log {info.log}")


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
    not exit (only a process of this host that carries the node's creation mark; on an agent's
    host, by that agent: `_end_remote`). What was done."""
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
    remote = _end_remote(ctx, fqn, str(orphan.get("component") or ""), int(pid)) if pid is not None else None
    if remote is not None:
        return f"{lc} → finalized, {remote}" if lc in ("unconfigured", "inactive") else f"{lc}, {remote}"
    if pid is None or _wait_gone(pid, mark, ctx.args.timeout):
        return f"{lc} → finalized, exited" if lc in ("unconfigured", "inactive") else f"{lc}"
    for sig in (signal.SIGTERM, signal.SIGKILL):
        if _process(pid, mark):
            os.kill(pid, sig)
            if _wait_gone(pid, mark, 3.0):
                return f"{lc}; did not exit, ended by {sig.name}"
    raise StepFailed(f"the orphan {fqn} (pid {pid}) did not exit")


def end_orphans(ctx: Context) -> str:
    """End every orphan a recovery's plan lists, before its first step; why one could not be
    ended ("": every one was)."""
    for orphan in ctx.orphans:
        ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
        try:
            how = end_orphan(ctx, orphan)
        except StepFailed as e:
            return str(e)
        ctx.say(f"ended the orphan {orphan['node']} (pid {orphan.get('pid') or 'unknown'}): {how}")
    return ""
