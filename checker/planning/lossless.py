"""No client request lost: the property a plan that names proxies to keep serving (`Plan.serving`,
`Plan.handover`; FTM transitions, docs/soundness.md#ftm-transitions) holds in every state, judged
by the Python engine. The Alloy plan module states the same (`lossless_states`)."""
from __future__ import annotations

from typing import Iterable, Optional, Sequence

from checker.planning.plan import Plan
from checker.semantic_model.actions import Snapshot, catalogue
from checker.semantic_model.config import Configuration

__all__ = ["reached", "reaches", "targets_of", "request_problems"]


def reached(st: Snapshot, origin: str, clients: set[str], holding: Iterable[str] = ()) -> set[str]:
    """The present components that what `origin` publishes (on any connector but the clients'
    connectors `clients`) reaches, through the readers of each connector and what those publish;
    a component of `holding` takes it and passes nothing on (a suspended protocol queues it)."""
    held = set(holding)
    seen, frontier = {origin}, [origin]
    while frontier:
        comp = frontier.pop()
        if comp != origin and comp in held:
            continue
        for conn in {k for k, _ in st.attached_outputs(comp)} - clients:
            for reader in st.readers([conn]) - seen:   # present components only
                seen.add(reader)
                frontier.append(reader)
    return seen - {origin}


def reaches(st: Snapshot, proxy: str, clients: set[str], targets: set[str]) -> bool:
    """Whether the requests `proxy` publishes (on any connector but the clients' connectors
    `clients`) reach a present protocol of `targets` (a suspended protocol queues them)."""
    return bool(reached(st, proxy, clients) & targets)


def targets_of(pairs: Iterable[tuple[str, str]]) -> dict[str, set[str]]:
    """proxy -> its protocols, from `Plan.protocols`' (proxy, protocol) pairs."""
    out: dict[str, set[str]] = {}
    for proxy, protocol in pairs:
        out.setdefault(proxy, set()).add(protocol)
    return out


def request_problems(plan: Plan, states: Optional[Sequence[Configuration]] = None) -> list[str]:
    """Every state of `plan` (or of `states`, states of its system) in which a request could be
    lost: a `serving` proxy's requests reach none of its protocols (`Plan.protocols`), or a
    `handover` proxy that still publishes on its clients' connector has requests that reach
    none. A degraded proxy still relays (its degraded mode guarantees the types without the
    rate)."""
    if not plan.serving and not plan.handover:
        return []
    cat = catalogue(plan.system)
    clients = {conn for conn, _ in plan.serving + plan.handover}
    targets = targets_of(plan.protocols)
    out = []
    for k, state in enumerate(plan.states if states is None else states):
        st = Snapshot(cat, state)
        for conn, proxy in plan.serving:
            if not reaches(st, proxy, clients, targets.get(proxy, set())):
                out.append(f"state {k}: the requests of {proxy} reach no protocol")
        for conn, proxy in plan.handover:
            if conn not in {sent for sent, _ in st.attached_outputs(proxy)}:
                continue
            if not reaches(st, proxy, clients, targets.get(proxy, set())):
                out.append(f"state {k}: the requests of {proxy} reach no protocol while it still publishes on {conn}")
    return out
