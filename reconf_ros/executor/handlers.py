"""The six actions on the live system, one handler each (`HANDLERS`), as
docs/control-interface.md#the-six-actions states them: each checks on the node what the plan
relies on before acting, acts through the standard services, and leaves the effect to be read
back by the run (`observe.check_touched`).

A handler's contract: it is called with the step's deadline set (`Runtime.deadline`), the wire
condition before the step met (`wire_before`); it raises `StepFailed` with the reason
when the node is not as the plan expects or refuses; it returns once the node has answered
that the change is made."""
from __future__ import annotations

import time
from typing import Callable

from .conditions import wire_after, wire_before
from .context import Context
from .observe import wait_status
from .plan_states import State
from .processes import launch, on_agent, wait_removed
from .runtime import NOT_A_RECONF_NODE, StepFailed
from .steps import Step


def _adoptable(ctx: Context, comp: str, fqn: str) -> bool:
    """Whether the node `fqn` that runs already is `comp`'s and not active (a process an earlier
    run started and did not activate, or one deactivated): the create adopts it."""
    st = ctx.rt.status(fqn) or {}
    if st.get("component", ctx.names.declared(comp)) != ctx.names.declared(comp):
        return False
    try:
        return ctx.rt.lifecycle(fqn) in ("unconfigured", "inactive")
    except StepFailed:
        return False


def create(ctx: Context, step: Step) -> None:
    """Start the component's process (or adopt its node, there and not active), wait for its
    lifecycle services, configure and activate it; its monitor counts from then on."""
    comp, names = step.component, ctx.names
    if names.is_version(comp):        # X@new: a node name no other node has (X's may still run)
        names.locate([comp])
        if comp in names.placed and not _adoptable(ctx, comp, names.fqn(comp)):
            raise StepFailed(f"before the step, {comp} runs already (node {names.fqn(comp)})")
        names.placed.setdefault(comp, names.fresh(comp))
    fqn = names.fqn(comp)
    if fqn in ctx.rt.nodes() or ctx.rt.node.count_services(f"{fqn}/get_state"):
        if _adoptable(ctx, comp, fqn):
            _adopt(ctx, comp, fqn)
            return baseline(ctx, comp)
        if not _finalized(ctx, fqn):
            raise StepFailed(f"before the step, a node {fqn} is already running")
        names.placed[comp] = names.fresh(comp)     # the finalized node stays while its process runs others
        ctx.say(f"      {fqn} is a finalized node that stays in its process: {comp} starts as {names.fqn(comp)}")
        fqn = names.fqn(comp)
    _start(ctx, comp, fqn)
    baseline(ctx, comp)


def _finalized(ctx: Context, fqn: str) -> bool:
    """Whether the node `fqn` says it is finalized (its lifecycle, or its last status)."""
    if (ctx.rt.status(fqn) or {}).get("lifecycle") == "finalized":
        return True
    try:
        return ctx.rt.lifecycle(fqn) == "finalized"
    except StepFailed:
        return False


def _adopt(ctx: Context, comp: str, fqn: str) -> None:
    lc = ctx.rt.lifecycle(fqn)
    pid = (ctx.rt.status(fqn) or {}).get("pid", "unknown")
    if lc == "unconfigured":
        ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_CONFIGURE, "configure")
    ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_ACTIVATE, "activate")
    ctx.say(f"      adopted {comp}'s node {fqn} (pid {pid}, {lc}: started and left so by an earlier run): activated")


def baseline(ctx: Context, comp: str) -> None:
    """Take a new node's monitor's count of violations as it comes up: from then on it counts in
    every step's check and the final one (docs/executor.md)."""
    if wait_status(ctx, comp, lambda st: st.get("lifecycle") == "active", min(3.0, ctx.rt.left())):
        ctx.baseline[comp] = int((ctx.rt.status(ctx.names.fqn(comp)) or {}).get("violations", "0"))


def _start(ctx: Context, comp: str, fqn: str) -> None:
    """Start the component's process as `fqn` (here, or on its host by its agent: `launch`),
    wait for its lifecycle services, configure and activate it."""
    started = ctx.started[comp] = launch(ctx, comp)
    proc, cmd, log = started.proc, started.command, started.log
    ctx.ended.discard(comp)
    ctx.say(f"      started {comp}: pid {proc.pid}{started.how}, log {log}")
    ctx.rt.forget(fqn)
    t0 = time.monotonic()
    cli = ctx.rt.client(ctx.rt.GetState, f"{fqn}/get_state")
    plain: dict[str, float] = {}
    while not cli.service_is_ready():
        if proc.poll() is not None:
            raise StepFailed(f"{cmd} exited with status {proc.returncode} before {comp} came up "
                             f"(see {log})")
        _not_a_lifecycle_node(ctx, comp, fqn, plain)
        ctx.rt.wait(cli.service_is_ready, min(0.2, ctx.rt.left()))
    t_up = time.monotonic()
    if ctx.rt.nodes().count(fqn) > 1:
        raise StepFailed(f"two nodes named {fqn} are running")
    lc = ctx.rt.lifecycle(fqn)
    t_state = time.monotonic()
    if lc == "unconfigured":
        ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_CONFIGURE, "configure")
    elif lc != "inactive":
        raise StepFailed(f"after start, {comp} is in lifecycle state {lc!r}")
    ctx.rt.transition(fqn, ctx.rt.Transition.TRANSITION_ACTIVATE, "activate")
    ctx.say(f"      {comp}'s services seen after {t_up - t0:.2f} s (process start and discovery), first answer "
            f"{t_state - t_up:.2f} s later, configured and activated in {time.monotonic() - t_state:.2f} s")


NOT_LIFECYCLE_AFTER = 1.5   # s a new node may serve parameters without lifecycle services before it is called plain


def _not_a_lifecycle_node(ctx: Context, comp: str, fqn: str, seen: dict[str, float]) -> None:
    """Fail at once, not at the step's timeout, when the process's node runs and serves its
    parameters but has had no lifecycle services for NOT_LIFECYCLE_AFTER s: not a reconf node."""
    node = ctx.rt.node
    if fqn in ctx.rt.nodes() and node.count_services(f"{fqn}/get_parameters") and \
            not node.count_services(f"{fqn}/get_state"):
        if time.monotonic() - seen.setdefault("since", time.monotonic()) > NOT_LIFECYCLE_AFTER:
            raise StepFailed(f"{comp}'s process runs node {fqn}, which serves no lifecycle services: not a reconf "
                             f"node; {NOT_A_RECONF_NODE}")
    else:
        seen.pop("since", None)


def remove(ctx: Context, step: Step) -> None:
    """Take an isolated node down its lifecycle to finalized; wait for a process this run started,
    and, for a component on an agent's host, for the agent's report of its process's exit
    (`wait_removed`: an agent that cannot be reached fails the step, naming the host)."""
    comp = step.component
    fqn, transition = ctx.names.fqn(comp), ctx.rt.Transition
    lc = ctx.rt.lifecycle(fqn)
    if lc not in ("active", "inactive"):
        raise StepFailed(f"before the step, {comp} is in lifecycle state {lc!r}")
    ports = [p["name"] for p in ctx.model.comps[comp]["ports"]]
    attached = {n: v for n, v in ctx.rt.get(fqn, [f"reconf.port.{p}" for p in ports]).items() if v}
    if attached:
        raise StepFailed(f"before the step, {comp} is not isolated: "
                         + ", ".join(f"{n}={v!r}" for n, v in sorted(attached.items())))
    pid = (ctx.rt.status(fqn) or {}).get("pid") if on_agent(ctx, comp) else None
    if lc == "active":
        ctx.rt.transition(fqn, transition.TRANSITION_DEACTIVATE, "deactivate")
    ctx.rt.transition(fqn, transition.TRANSITION_CLEANUP, "cleanup")
    ctx.rt.transition(fqn, transition.TRANSITION_UNCONFIGURED_SHUTDOWN, "shutdown")
    # finalized: the node may exit at once, which counts as removed
    try:
        lc = ctx.rt.lifecycle(fqn)
    except StepFailed:
        lc = "finalized"
    if lc != "finalized":
        raise StepFailed(f"after shutdown, {comp} is in lifecycle state {lc!r}")
    # its process may exit at any moment, and its node linger in the graph not answering: a
    # reading after this step must not ask it (it would wait for the call's timeout)
    ctx.ended.add(comp)
    seen = wait_removed(ctx, comp, int(str(pid)) if str(pid or "").isdigit() else None,
                        max(0.1, min(ctx.args.timeout, ctx.rt.deadline - time.monotonic())))
    if seen:
        ctx.say(f"      {comp}: {seen}")
    ctx.rt.forget(fqn)


def _port(ctx: Context, step: Step, attach: bool) -> None:
    """Set `reconf.port.<p>` to its current list with the connector added (or taken away)."""
    comp, port, conn = step.component, step.port, ctx.names.connector(step.connector)
    fqn, name = ctx.names.fqn(comp), f"reconf.port.{port}"
    _expect_active(ctx, comp)
    now = ctx.rt.get(fqn, [name])[name]
    if (conn in now) == attach:
        raise StepFailed(f"before the step, {comp}.{port} is {'already' if attach else 'not'} attached to "
                         f"{conn} ({name}={now!r})")
    ctx.rt.set(fqn, name, sorted(set(now) | {conn}) if attach else [c for c in now if c != conn])


def _mode(ctx: Context, step: Step, was: str, will: str) -> None:
    """Set `reconf.mode.<f>` from `was` to `will`."""
    comp, func = step.component, step.functionality
    fqn, name = ctx.names.fqn(comp), f"reconf.mode.{func}"
    _expect_active(ctx, comp)
    now = ctx.rt.get(fqn, [name])[name]
    if now != was:
        raise StepFailed(f"before the step, {comp}.{func} is {now!r}, not {was!r}")
    ctx.rt.set(fqn, name, will)


def _expect_active(ctx: Context, comp: str) -> None:
    lc = ctx.rt.lifecycle(ctx.names.fqn(comp))
    if lc != "active":
        raise StepFailed(f"before the step, {comp} is in lifecycle state {lc!r}")


HANDLERS: dict[str, Callable[[Context, Step], None]] = {
    "create": create,
    "remove": remove,
    "attach": lambda ctx, step: _port(ctx, step, attach=True),
    "detach": lambda ctx, step: _port(ctx, step, attach=False),
    "degrade": lambda ctx, step: _mode(ctx, step, "normal", "degraded"),
    "upgrade": lambda ctx, step: _mode(ctx, step, "degraded", "normal"),
}


def perform(ctx: Context, step: Step, was: State, will: State) -> None:
    """One step: its wire condition before, its handler, its wire condition after."""
    ctx.rt.deadline = time.monotonic() + ctx.args.step_timeout
    ctx.began = time.time()
    wire_before(ctx, step, was, will)
    HANDLERS[step.action](ctx, step)
    wire_after(ctx, step, will)
