"""Prepare first, clean up last: a plan's steps ordered for its time on the wire
(docs/soundness.md#prepare-first-clean-up-last).

A component the plan creates serves no one until its first upgrade: its `create` and the
attaches of its inputs before that upgrade (*preparing* steps) disturb nothing that runs, and a
`remove` takes away a component nothing reads any more. On the wire a create is the slowest
step by far (a process start and a discovery round, `KINDS`' `seconds`), so where it falls
inside a degraded window it is most of that window. `prepare_first` moves the preparing steps,
in their order, before everything else and the removes after everything else, where every
step's preconditions still hold (each move is checked on its own, so one that would break a
state is left where it was), and keeps the new order only when its degraded seconds
(`checker.planning.durations`) are lower. The plan is then verified as any plan.

Where live traffic must not reach a new component before its turn (an FTM transition, whose new
nodes act on the application's state), `isolated` takes instead the steps that link new
components only among themselves: a new component's attach to a connector no present old
component is attached to (or as a client of a service, which answers only what it is asked),
and its upgrades, each when every earlier step on that component is taken too. Nothing that
serves can send a new layer a request before the suspension then, whatever the layer's nodes do.
At the other end it takes the steps that unlink removed components only from each other, and
their degrades and removes (`_cut_off`): an old layer once its links to what stays are cut.
"""
from __future__ import annotations

from typing import Sequence, Union

from checker.planning.durations import Durations, degraded_seconds
from checker.planning.improve import cost
from checker.planning.plan import Goal
from checker.semantic_model.actions import Action, Attach, Create, Degrade, Detach, Remove, Upgrade
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System

__all__ = ["prepare_first", "service_client"]

TRIALS = 200
"""How many orders the single moves may check, at most (each check replays the plan)."""


def _preparing(system: System, start: Configuration, steps: Sequence[Action], inputs: bool) -> list[int]:
    """The indices of the preparing steps: creates of new components, and (with `inputs`)
    attaches of their inputs before their first upgrade."""
    new = {a.component for a in steps if isinstance(a, Create) and a.component not in start.components}
    upgraded: set[str] = set()
    out = []
    for i, a in enumerate(steps):
        if isinstance(a, Upgrade):
            upgraded.add(a.component)
        elif isinstance(a, Create) and a.component in new:
            out.append(i)
        elif inputs and isinstance(a, Attach) and a.component in new and a.component not in upgraded:
            comp = system.component(a.component)
            port = comp.port(a.port) if comp is not None else None
            if port is not None and port.kind == "input":
                out.append(i)
    return out


def _isolated(system: System, start: Configuration, steps: Sequence[Action]) -> list[int]:
    """The indices of the steps on new components that link them only among themselves, in the
    state the steps taken before them make from `start`."""
    new = {a.component for a in steps if isinstance(a, Create) and a.component not in start.components}
    roles, stuck, out = set(start.roles), set(), []
    for i, a in enumerate(steps):
        comp = getattr(a, "component", "")
        if comp not in new or comp in stuck:
            continue
        if isinstance(a, Attach) and not _apart(system, roles, new, a):
            stuck.add(comp)
            continue
        if isinstance(a, (Create, Attach, Upgrade)):
            out.append(i)
            if isinstance(a, Attach):
                roles.add((a.connector, a.component, a.port))
        else:
            stuck.add(comp)
    return out


def _cut_off(system: System, start: Configuration, steps: Sequence[Action]) -> list[int]:
    """The indices of the steps on removed components that unlink them only from each other (no
    component that stays is attached to the connector by then, or as the server of a service the
    removed component was a client of), and their degrades and removes: each when every later
    step on that component is taken too."""
    removed = {a.component for a in steps if isinstance(a, Remove)}
    end = set(start.roles)
    for a in steps:
        if isinstance(a, Attach):
            end.add((a.connector, a.component, a.port))
        elif isinstance(a, Detach):
            end.discard((a.connector, a.component, a.port))
    stuck: set[str] = set()
    out = []
    for i in range(len(steps) - 1, -1, -1):
        a = steps[i]
        comp = getattr(a, "component", "")
        if comp not in removed or comp in stuck:
            continue
        if isinstance(a, (Degrade, Remove)) or (isinstance(a, Detach) and _apart(system, end, removed, a)):
            out.append(i)
        else:
            stuck.add(comp)
    return out[::-1]


def _apart(system: System, roles: set[tuple[str, str, str]], new: set[str], a: Union[Attach, Detach]) -> bool:
    """Whether `a` joins (parts) its component to (from) components of `new` only, attached as
    in `roles`, or makes (unmakes) it a client of a service."""
    if service_client(system, a.connector, a.component, a.port):
        return True
    return all(c in new for k, c, _ in roles if k == a.connector)


def service_client(system: System, connector: str, component: str, port: str) -> bool:
    """Whether `component.port` is a client's side of service `connector` (it is answered only
    what it asks)."""
    conn, comp = system.connector(connector), system.component(component)
    p = comp.port(port) if comp is not None else None
    return conn is not None and conn.kind == "service" and p is not None and p.kind == "input"


def _move(system: System, start: Configuration, steps: list[Action], goal: Goal, picked: list[int],
          front: bool) -> list[Action]:
    """`steps` with the `picked` ones (indices) moved to the front (the back), in their order,
    all at once where the checks allow, or else each on its own as far as they allow."""
    if not picked:
        return steps
    chosen = set(picked)
    moved = [steps[i] for i in picked]
    rest = [a for i, a in enumerate(steps) if i not in chosen]
    cand = moved + rest if front else rest + moved
    if cand == steps:
        return steps
    if cost(system, start, cand, goal) is not None:      # every precondition holds, the goal is reached
        return cand
    tagged, trials = list(enumerate(steps)), TRIALS
    for k in picked if front else reversed(picked):
        i = next(n for n, (orig, _) in enumerate(tagged) if orig == k)
        item, others = tagged[i], tagged[:i] + tagged[i + 1:]
        for j in (range(0, i) if front else range(len(others), i, -1)):
            trials -= 1
            if trials < 0:
                return [a for _, a in tagged]
            trial = others[:j] + [item] + others[j:]
            if cost(system, start, [a for _, a in trial], goal) is not None:
                tagged = trial
                break
    return [a for _, a in tagged]


def prepare_first(system: System, start: Configuration, steps: list[Action], goal: Goal,
                  times: Durations, inputs: bool = True, removes: bool = True,
                  isolated: bool = False) -> list[Action]:
    """`steps` with the preparing steps first (the creates, and with `inputs` the attaches of the
    new components' inputs; with `isolated` the steps that link new components only among
    themselves instead) and (with `removes`) the removes last, where that keeps every
    precondition and lowers the degraded seconds; `steps` unchanged otherwise."""
    before = degraded_seconds(system, start, steps, times).weighted    # `steps` is a checked plan
    if not before:
        return steps
    picked = _isolated(system, start, steps) if isolated else _preparing(system, start, steps, inputs)
    out = _move(system, start, steps, goal, picked, front=True)
    if removes:
        last = _cut_off(system, start, out) if isolated else [i for i, a in enumerate(out) if isinstance(a, Remove)]
        out = _move(system, start, out, goal, last, front=False)
    # every order `_move` returns was checked
    return out if degraded_seconds(system, start, out, times).weighted < before else steps
