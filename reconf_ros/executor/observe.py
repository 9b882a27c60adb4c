"""Reading the live system: each component's node (lifecycle state, modes, attachments) as a
configuration the semantics can judge, after discovery has settled; the monitors' counters."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Iterable

from .context import Context
from .plan_states import State
from .runtime import NoControlInterface, StepFailed
from .status import Status


@dataclass
class Observed:
    """What the executor saw of one component's node: `lifecycle` is its state's label,
    `absent` (not in the graph, or finalized), `unresponsive` (in the graph, not answering) or
    `not a reconf node` (answering, without the lifecycle services, or without this component's
    parameters: a node of another version of it, or no reconf node)."""
    comp: str
    lifecycle: str
    modes: dict[str, str] = field(default_factory=dict)
    ports: dict[str, list[str]] = field(default_factory=dict)
    why: str = ""                   # what the node answered, when that is why it is not the component

    @property
    def present(self) -> bool:
        return self.lifecycle == "active"


def _control_parameters(ctx: Context, comp: str) -> list[str]:
    info = ctx.model.comps[comp]
    return [f"reconf.mode.{f['name']}" for f in info["functionalities"]] + \
        [f"reconf.port.{p['name']}" for p in info["ports"]]


def observe(ctx: Context, comps: Iterable[str]) -> dict[str, Observed]:
    """Read each component's node: lifecycle state, modes, attachments; every node at once.
    `ctx.read_at` is when the reading began (what happens to a node after may not be in it)."""
    ctx.read_at = round(time.time(), 3)
    comps, names = sorted(comps), ctx.names
    graph = set(ctx.rt.nodes())
    names.locate(comps, graph)
    # a node this run saw finalized, or whose process exited, may stay in the graph a while (on
    # another host, seconds): it is absent, and asking it would wait for the timeout
    seen = {c: Observed(c, "absent") for c in comps if names.fqn(c) not in graph or c in ctx.ended}
    # the lifecycle state and the parameters of each at once; the parameters of an active one read
    states, params = ctx.rt.read({names.fqn(c): _control_parameters(ctx, c) for c in comps if c not in seen})
    active = set()
    for c in comps:
        lc = states.get(names.fqn(c))
        if c in seen or lc is None:
            continue
        if isinstance(lc, StepFailed):    # in the graph, but not answering: say so, do not guess
            seen[c] = Observed(c, "not a reconf node") if isinstance(lc, NoControlInterface) else _silent(ctx, c)
        elif lc != "active":
            seen[c] = Observed(c, "absent" if lc == "finalized" else lc)
        else:
            active.add(c)
    for c in comps:
        values = params.get(names.fqn(c))
        if c not in active or values is None:
            continue
        if isinstance(values, NoControlInterface):  # it answered, without the parameters of this
            seen[c] = Observed(c, "not a reconf node", why=str(values))  # component (another version?)
            continue
        if isinstance(values, StepFailed):    # it answered get_state, then not: say so, do not guess
            seen[c] = _silent(ctx, c, str(values))
            continue
        modes = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.mode.")}
        ports = {n.split(".", 2)[2]: v for n, v in values.items() if n.startswith("reconf.port.")}
        seen[c] = Observed(c, "active", modes, ports)
    return dict(sorted(seen.items()))


def _silent(ctx: Context, comp: str, why: str = "") -> Observed:
    """A node in the graph that did not answer: absent if the process this run started for it
    has exited, else unresponsive, never guessed at."""
    return Observed(comp, "absent" if _exited(ctx, comp) else "unresponsive", why=why)


def _exited(ctx: Context, comp: str) -> bool:
    """Whether the process this run started for `comp` has exited, or this run saw the component
    end at its remove (a node gone stays in the graph a while, not answering: it is absent, not
    unknown)."""
    info = ctx.started.get(comp)
    return comp in ctx.ended or (info is not None and info.proc.poll() is not None)


def as_state(ctx: Context, seen: dict[str, Observed]) -> State:
    """The configuration the nodes showed: the active ones present, their modes and attachments."""
    back = {v: k for k, v in ctx.names.renames.items()}
    comps = [c for c, o in seen.items() if o.present]
    degraded = [(c, f) for c in comps for f, m in seen[c].modes.items() if m != "normal"]
    roles = [(back.get(k, k), c, p) for c in comps for p, ks in seen[c].ports.items() for k in ks]
    return State(comps, degraded, roles)


def read_all(ctx: Context) -> tuple[State, dict[str, Observed]]:
    """Every component of the model read: the configuration, and what each node showed (the
    components whose node did not answer noted in `ctx.unread`: the configuration says
    nothing of them)."""
    seen = observe(ctx, ctx.model.comps)
    ctx.unread = {c for c, o in seen.items() if o.lifecycle == "unresponsive"}
    return as_state(ctx, seen), seen


def neighbourhood(ctx: Context) -> set[str]:
    """The components the plan touches, and those attached to a connector it touches."""
    comps = {s.component for s in ctx.steps}
    conns = {s.connector for s in ctx.steps if s.connector}
    for st in ctx.states:
        conns |= {n for n, c, p in st.roles if c in comps}
    for st in ctx.states:
        comps |= {c for n, c, p in st.roles if n in conns}
    return comps & set(ctx.model.comps)


def settle(ctx: Context, expected: Iterable[str], seconds: float) -> None:
    """Let discovery catch up before reading the graph (bounded by `seconds`): every node the
    plan expects running seen, one announcement period passed, and the graph unchanged for a
    while. A node the plan expects absent but that runs must not be missed (a re-run would
    start a second one)."""
    expected = set(expected)

    def want(nodes: set[str]) -> set[str]:
        ctx.names.locate(expected, nodes)
        return {ctx.names.fqn(c) for c in expected}
    ctx.rt.wait(lambda: ctx.rt.settled(want), seconds)


def wait_status(ctx: Context, comp: str, cond: Callable[[Status], bool], seconds: float) -> bool:
    """Wait (bounded) until the component's node shows a status that meets `cond`."""
    return ctx.rt.wait(lambda: (st := ctx.rt.status(ctx.names.fqn(comp))) is not None and cond(st), seconds)


def wait_statuses(ctx: Context, comps: Iterable[str]) -> None:
    """Wait (bounded) for a status from each running component, so violations can be counted."""
    want = list(comps)
    ctx.rt.wait(lambda: all(ctx.rt.status(ctx.names.fqn(c)) is not None for c in want), 3.0)


def violations(ctx: Context, comps: Iterable[str]) -> dict[str, int]:
    """Each heard-from component's monitor's count of normal-mode assumptions violated."""
    out = {}
    for c in comps:
        st = ctx.rt.status(ctx.names.fqn(c))
        if st is not None:
            out[c] = int(st.get("violations", "0"))
    return out


def last_violations(ctx: Context, comps: Iterable[str]) -> dict[str, str]:
    """Each heard-from component's monitor's last violation, as its status says it (when it began on
    the wall clock, the functionality, why), if it saw any."""
    out = {}
    for c in comps:
        last = (ctx.rt.status(ctx.names.fqn(c)) or {}).get("last_violation")
        if last:
            out[c] = last
    return out


def largest_gaps(ctx: Context, comps: Iterable[str]) -> dict[str, float]:
    """Each heard-from monitored input's largest wait for data since its node started
    (`in.<port>.max_gap_s` of its status, docs/control-interface.md): "component.port" -> s."""
    out = {}
    for c in comps:
        for key, value in (ctx.rt.status(ctx.names.fqn(c)) or {}).items():
            if key.startswith("in.") and key.endswith(".max_gap_s"):
                out[f"{c}.{key[3:-len('.max_gap_s')]}"] = float(value)
    return out


def check_touched(ctx: Context, expected: State, when: str) -> None:
    """Every component the plan has touched reads back as `expected` has it."""
    # a node that answered its services may not be in this node's graph yet, nor heard on
    # /diagnostics: under load, discovery lags behind the services by seconds
    want = {ctx.names.fqn(c) for c in ctx.touched & expected.components}
    ctx.rt.wait(lambda: want <= set(ctx.rt.nodes()), ctx.args.discovery_timeout)
    seen = observe(ctx, ctx.touched)
    diffs = ctx.model.differences(expected, as_state(ctx, seen), ctx.touched)
    if diffs:
        raise StepFailed(f"{when}: " + "; ".join(diffs + [o.why for _, o in sorted(seen.items()) if o.why]))


def unusual(ctx: Context, seen: dict[str, Observed]) -> None:
    """Say which nodes are neither absent nor active (inactive, unresponsive, …)."""
    for c, o in sorted(seen.items()):
        if o.lifecycle not in ("absent", "active"):
            ctx.warn(f"    ({c} is {o.lifecycle}: not counted as present{': ' + o.why if o.why else ''})")
