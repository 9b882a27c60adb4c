"""The conditions a step waits for on the wire, read from the nodes' statuses
(docs/control-interface.md#the-six-actions): before a step, an upgraded functionality's
assumptions met, with its inputs received since the step began, and every reader of a
connector that loses a publisher receiving, since the step began, from one that stays; after
it, an attached port matched with the other side of its connector and, for a publishing
output, its data received; after a degrade, nothing left in flight where the node says what it
has."""
from __future__ import annotations

from typing import Callable, Optional

from .context import Context
from .observe import wait_status
from .plan_states import State
from .runtime import StepFailed
from .semantics import rate
from .status import Status
from .steps import Step, plural


def meets(func: str) -> Callable[[Status], bool]:
    """Whether a status shows `func`'s normal assumptions met on the wire (or not observed)."""
    return lambda st: st.get(f"wire.{func}", "").split(":")[0] in ("met", "unobserved")


def on_demand(ctx: Context, comp: str, port: str) -> bool:
    """Whether data reaches `comp.port` only when asked for (an FTM's requests and results,
    its status says; or its assumption has no rate): no data may flow while a step runs."""
    st = ctx.rt.status(ctx.names.fqn(comp)) or {}
    declared = ctx.model.port(comp, port)
    return st.get(f"in.{port}.on_demand") == "1" or rate(declared["assumption"] if declared else None) is None


def publishes(ctx: Context, comp: str, port: str, state: State) -> bool:
    """Whether `comp.port`'s functionality guarantees data at a rate there in `state`'s mode
    (data without a rate comes on demand: an FTM's requests, say; matching is all there is
    to wait for)."""
    for f in ctx.model.comps[comp]["functionalities"]:
        if port in f["ports"]:
            g = ctx.model.guarantee(ctx.model.mode(comp, f, state), port)
            if g is not None and g.get("message") is not None and g.get("hz") is not None:
                return True
    return False


def _ends(ctx: Context, conn: str, state: State, kind: str) -> list[tuple[str, str]]:
    """The present (component, port) pairs of `kind` ("input", "output") attached to `conn`."""
    return [(c, p) for n, c, p in sorted(state.roles)
            if n == conn and c in state.components and ctx.model.port_kind(c, p) == kind]


def wire_before(ctx: Context, step: Step, was: State, will: State) -> None:
    """What the wire must show before the step: an upgraded functionality's assumptions met;
    a connector that loses a publisher still delivering from the ones that remain."""
    if step.action == "upgrade":
        _assumptions_hold(ctx, step)
    for conn in ctx.model.conns:
        kept = ctx.model.satisfying(will, conn)
        if kept and not set(kept) >= set(ctx.model.satisfying(was, conn)):
            _readers_keep_data(ctx, step, conn, kept, was, will)


def _assumptions_hold(ctx: Context, step: Step) -> None:
    """The upgraded functionality's assumptions met, in a status that shows each input it relies
    on at a rate received since the step began: a verdict of "met" can be a silence old, since a
    node calls a silence a gap only when its timer next looks (after up to twice the limit)."""
    comp, f = step.component, step.functionality
    fed = _rated_inputs(ctx, comp, f)
    _ask(ctx, [(comp, p) for p in fed])
    if wait_status(ctx, comp, lambda st: meets(f)(st) and all(_heard_since(st, p, ctx.began) for p in fed),
                   ctx.args.wire_timeout):
        return
    st = ctx.rt.status(ctx.names.fqn(comp)) or {}
    silent = [p for p in fed if not _heard_since(st, p, ctx.began)]
    raise StepFailed(f"{comp}.{f}: its assumptions are not met on the wire "
                     f"({st.get(f'wire.{f}', 'no status from the node')})" + (
                         f"; nothing received on {', '.join(silent)} since the step began" if st and silent else ""))


def _rated_inputs(ctx: Context, comp: str, func: str) -> list[str]:
    """The inputs `comp`'s functionality `func` relies on in its normal mode for data at a rate
    (not an FTM's requests and results, which come on demand)."""
    return sorted({p for f in ctx.model.comps[comp]["functionalities"] if f["name"] == func
                   for p, a in ctx.model.relied_on(comp, f) if rate(a) is not None and not on_demand(ctx, comp, p)})


def _ask(ctx: Context, inputs: list[tuple[str, str]]) -> None:
    """Ask the nodes of these (component, input) pairs for the status that shows a reception
    since the step began (docs/control-interface.md#asked-status)."""
    if inputs:
        ctx.rt.ask(ctx.began, [(ctx.names.fqn(c), p) for c, p in inputs])


def _readers_keep_data(ctx: Context, step: Step, conn: str, kept: list[str], was: State, will: State) -> None:
    """Every reader relying on `conn` receives from a publisher that stays (`kept`); a reader of
    data on demand is matched with every publisher it had, the ones that stay among them."""
    names = {ctx.names.node_name(c) for c in kept}
    k, wait = ctx.names.connector(conn), ctx.args.wire_timeout
    matched = len(_ends(ctx, conn, was, "output"))
    readers = [(r, p) for r, p in _ends(ctx, conn, will, "input") if p in ctx.model.relying_inputs(r, will)]
    fed = [(r, p) for r, p in readers if not on_demand(ctx, r, p)]
    _ask(ctx, fed)
    for reader, port in readers:
        key = f"in.{port}@{k}.publishers"
        if (reader, port) not in fed:
            # data on demand (an FTM's requests): none may flow now
            if not wait_status(ctx, reader, lambda st: int(st.get(key, "0")) >= matched, wait):
                st = ctx.rt.status(ctx.names.fqn(reader)) or {}
                raise StepFailed(f"{reader}.{port} is matched with {st.get(key, 'no')} of the "
                                 f"{plural(matched, 'publisher')} of {k}; taking {step.component}'s away "
                                 "could leave it without one")
        elif not wait_status(ctx, reader, lambda st: bool(_heard_since(st, port, ctx.began, names)), wait):
            st = ctx.rt.status(ctx.names.fqn(reader)) or {}
            raise StepFailed(f"{reader}.{port} has received nothing on {k} from {', '.join(sorted(names))} since the "
                             f"step began (fresh sources: {st.get(f'in.{port}.fresh') or 'none'}); taking "
                             f"{step.component}'s away would leave it without data")


def _heard_since(st: Status, port: str, since: float, nodes: Optional[set[str]] = None) -> list[str]:
    """The nodes (of `nodes`, or any) whose messages `port` received after `since` (wall clock),
    as the status shows: a publisher that died a moment ago vouches for nothing with what it sent
    before."""
    head = f"in.{port}.last."
    return sorted(k[len(head):] for k, v in st.items()
                  if k.startswith(head) and float(v or 0) > since and (nodes is None or k[len(head):] in nodes))


def wire_after(ctx: Context, step: Step, will: State) -> None:
    """An attached port is matched with the other side of its connector as the plan has it; an
    attached output that publishes is heard by every subscriber; a degraded functionality that
    reports what it has in flight has none left (`drained`)."""
    if step.action == "degrade":
        return drained(ctx, step)
    if step.action != "attach":
        return
    comp, port, conn = step.component, step.port, step.connector
    k, wait = ctx.names.connector(conn), ctx.args.wire_timeout
    pubs, subs = _ends(ctx, conn, will, "output"), _ends(ctx, conn, will, "input")
    kind = ctx.model.port_kind(comp, port)
    if kind == "output" and subs:
        key = f"out.{port}@{k}.subscribers"
        if not wait_status(ctx, comp, lambda st: int(st.get(key, "0")) >= len(subs), wait):
            raise StepFailed(f"{comp}.{port} is not matched with the {plural(len(subs), 'subscriber')} of {k} "
                             f"within {wait} s")
    for c, p in (subs if kind == "output" else [(comp, port)]):
        key = f"in.{p}@{k}.publishers"
        if pubs and not wait_status(ctx, c, lambda st: int(st.get(key, "0")) >= len(pubs), wait):
            raise StepFailed(f"{c}.{p} is not matched with the {plural(len(pubs), 'publisher')} of {k} "
                             f"within {wait} s")
    if kind == "output" and publishes(ctx, comp, port, will):
        # Matched counts can be stale (a publisher just gone still counted): the data decides.
        me = f"in.{{}}.from.{ctx.names.node_name(comp)}"
        for c, p in subs:
            if on_demand(ctx, c, p):
                continue            # nothing flows until asked for; matched above
            if not wait_status(ctx, c, lambda st: me.format(p) in st, wait):
                raise StepFailed(f"{c}.{p} has received nothing from {comp} on {k} within {wait} s")


def drained(ctx: Context, step: Step) -> None:
    """After a degrade: a functionality whose status reports `in_flight.<f>` (an FTM protocol:
    the requests inside its layer) shows itself degraded with none in flight. A suspension is
    complete only then: a plan that re-links the layer before would cut a request off inside it
    (docs/control-interface.md#the-six-actions)."""
    comp, f = step.component, step.functionality
    key = f"in_flight.{f}"
    if key not in (ctx.rt.status(ctx.names.fqn(comp)) or {}):
        return
    if not wait_status(ctx, comp, lambda st: st.get(f"mode.{f}") == "degraded" and st.get(key) == "0",
                       ctx.args.wire_timeout):
        st = ctx.rt.status(ctx.names.fqn(comp)) or {}
        raise StepFailed(f"{comp}.{f} still has {st.get(key, 'some')} requests in flight "
                         f"{ctx.args.wire_timeout} s after it was degraded")
