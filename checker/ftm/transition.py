"""FTM transitions as verified plans (paper 000 §6: suspend, substitute, link, resume).

A transition is a migration between two expanded architectures, the old FTM's graph and the new
one's, planned in three parts: suspend the protocols whose neighbourhood changes, substitute and
link with them kept suspended, resume. Which protocols are suspended, why no request is lost, and
what `request_problems` checks on every state: docs/soundness.md#ftm-transitions.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from typing import Optional, Union

from checker.ftm.diagnose import ftm_diagnostics
from checker.ftm.expand import ExpansionInfo, FtmRuleBroken, expand
from checker.ftm.library import LAYER_ORDER
from checker.planning import Goal, NoSafePlan, Plan, Problem, plan_migrate, solve
from checker.planning.durations import durations
from checker.planning.improve import cost
from checker.planning.lossless import reached, reaches, request_problems, targets_of
from checker.planning.plan import settle, verify
from checker.planning.prepare import prepare_first, service_client
from checker.semantic_model.actions import (
    Action,
    Attach,
    Degrade,
    Detach,
    Remove,
    Snapshot,
    Upgrade,
    catalogue,
    effect,
    failing_assumptions,
    preconditions,
)
from checker.semantic_model.config import Configuration, FuncId
from checker.semantic_model.semantics import evaluate
from reconf_dsl import ir
from reconf_dsl.ir import satisfies
from reconf_dsl.parser import parse_text

__all__ = ["Transition", "parse_ftm", "with_ftm", "plan_transition", "plan_ftm_migrate", "expand_for_planning",
           "suspension_problems", "client_side_ok", "protocols", "reaches_protocol", "handover",
           "request_problems"]


def parse_ftm(text: str) -> ir.FtmExpr:
    """`"SEC(PBR(TR))"` → FtmExpr, through the DSL's own grammar."""
    doc = parse_text(f"system x\ncomponent c {{ ftm {text} }}\n", "<ftm>")
    comp = next(i for i in doc.items if isinstance(i, ir.Component))
    assert comp.ftm is not None
    return comp.ftm.expr


def with_ftm(system: ir.System, component: str, expr: Optional[ir.FtmExpr],
             hosts: Optional[tuple[str, ...]] = None) -> ir.System:
    """`system` with `component`'s FTM set to `expr` (None removes it), on `hosts` (default: as before)."""
    comps = []
    found = False
    for c in system.components:
        if c.name == component:
            found = True
            old_hosts = c.ftm.hosts if c.ftm is not None else ()
            decl = None if expr is None else ir.FtmDecl(expr, hosts if hosts is not None else old_hosts,
                                                        c.ftm.span if c.ftm is not None else c.span)
            c = dc_replace(c, ftm=decl)
        comps.append(c)
    if not found:
        raise NoSafePlan([f"no deployed component '{component}'"])
    return dc_replace(system, components=tuple(comps))


def expand_for_planning(system: ir.System) -> tuple[ir.System, list[ExpansionInfo]]:
    """The architecture the planners work on: every FTM expanded."""
    return expand(system)


@dataclass
class Transition:
    plan: Plan
    old: ir.System                     # expanded
    new: ir.System                     # expanded
    old_infos: list[ExpansionInfo]
    new_infos: list[ExpansionInfo]
    suspended: list[str] = field(default_factory=list)   # protocols that had to be suspended
    presuspended: bool = False                         # whether suspension was added before planning


def _layer_of(name: str, info: ExpansionInfo) -> tuple[int, int]:
    rest = name[len(info.server) + 2:]          # r0_dup_protocol
    replica, layer = rest.split("_")[0], rest.split("_")[1]
    return int(replica[1:]), LAYER_ORDER.index(layer)


def _region(info: ExpansionInfo, replica: int, depth: int) -> set[str]:
    """Names of the nodes of `replica` at layer index ≥ depth, and the replica's application."""
    out = set()
    prefix = f"{info.server}__r{replica}_"
    for n in info.components:
        if n.startswith(prefix):
            tail = n[len(prefix):]
            layer = tail.split("_")[0]
            if layer in LAYER_ORDER and LAYER_ORDER.index(layer) >= depth:
                out.add(n)
            elif tail == "app":
                out.add(n)
        if replica == 0 and n == info.server:
            out.add(n)
    return out


def _roles_of(system: ir.System, names: set[str]) -> set[tuple[str, str, str]]:
    return {(c.name, r.component, r.port) for c in system.connectors for r in c.roles if r.component in names}


def affected_protocols(old: ir.System, new: ir.System, old_info: ExpansionInfo,
                       new_info: ExpansionInfo) -> dict[str, set[str]]:
    """Surviving protocols whose neighbourhood changes → the names (old and new) of that neighbourhood."""
    out: dict[str, set[str]] = {}
    for p in old_info.protocols:
        if p not in new_info.protocols or old.component(p) != new.component(p):
            continue
        replica, depth = _layer_of(p, old_info)
        hood = _region(old_info, replica, depth) | _region(new_info, replica, depth) | {p}
        olds = {n: old.component(n) for n in hood}
        news = {n: new.component(n) for n in hood}
        if olds != news or _roles_of(old, hood) != _roles_of(new, hood):
            out[p] = hood
    return out


def _touches(system: ir.System, a: Action, hood: set[str], renames: dict[str, str], state: Configuration,
             old: frozenset[str], kept: frozenset[str]) -> bool:
    """Whether `a`, taken in `state`, disturbs a running node of `hood`: detaches a port from a
    connector a node of `kept` (the plan's end) is attached to, or attaches a publisher that a
    node of `old` (the plan's start) reads; a service's client is not disturbed by the server's
    side and does not disturb it. Attaching a new node's input only prepares it, a publisher
    only new nodes read links the new layer, a detach from removed nodes only takes an old layer
    apart once it is cut off, and a remove takes a node attached to nothing."""
    if not isinstance(a, (Attach, Detach)) or (a.component not in hood and
                                               renames.get(a.component, a.component) not in hood):
        return False
    comp = system.component(a.component)
    port = comp.port(a.port) if comp is not None else None
    if port is None or service_client(system, a.connector, a.component, a.port):
        return False
    others = {c for k, c, _ in state.roles if k == a.connector and c != a.component}
    if isinstance(a, Attach):
        return port.kind == "output" and bool(others & old)
    return a.component in kept or bool(others & kept)


def _func(system: ir.System, comp: str) -> FuncId:
    c = system.component(comp)
    assert c is not None and c.functionalities
    return (comp, c.functionalities[0].name)


def suspension_problems(plan: Plan, hoods: dict[str, set[str]]) -> list[str]:
    """Why `plan` does not keep each affected protocol suspended while its neighbourhood changes:
    every step that disturbs a running node of the neighbourhood (or attaches or detaches one of
    the protocol's inputs) must run while the protocol is degraded, and the protocol must be
    normal at the end. Moving the protocol's own outputs is its restart and may follow."""
    out = []
    for p, hood in sorted(hoods.items()):
        fid = _func(plan.system, p)
        comp = plan.system.component(p)
        assert comp is not None
        for i, a in enumerate(plan.steps):
            own = isinstance(a, (Attach, Detach)) and a.component == p and \
                (comp.port(a.port) or _NOPORT).kind == "input"
            disturbs = _touches(plan.system, a, hood - {p}, plan.renames, plan.states[i], plan.states[0].components,
                                plan.states[-1].components)
            if (own or disturbs) and fid not in plan.states[i].degraded:
                out.append(f"{p} is not suspended at step {i + 1} ({a.describe()})")
                break
        if fid in plan.states[-1].degraded:
            out.append(f"{p} is not resumed at the end")
    return out


class _NoPort:
    kind = "none"


_NOPORT = _NoPort()


def _suspend_steps(system: ir.System, start: Configuration, funcs: list[FuncId]) -> list[Action]:
    """Degrade `funcs` and everything that would lose an assumption, in an order the
    preconditions accept (most dependent first)."""
    want = set(funcs)
    while True:
        failing = failing_assumptions(system, Configuration(start.components, frozenset(want), start.roles))
        new = {(c, f) for c, f, _ in failing} - want
        if not new:
            break
        want |= new
    steps: list[Action] = []
    config = start
    pending = sorted(want - set(config.degraded))
    while pending:
        for fid in pending:
            a = Degrade(*fid)
            if not preconditions(system, config, a):
                steps.append(a)
                config = Configuration(config.components, config.degraded | {fid}, config.roles)
                pending.remove(fid)
                break
        else:
            raise NoSafePlan([f"cannot suspend {', '.join(f'{c}.{f}' for c, f in pending)}"])
    return steps


def _resume_steps(system: ir.System, config: Configuration) -> list[Action]:
    """Upgrade every degraded functionality, each as soon as its preconditions hold."""
    steps: list[Action] = []
    pending = sorted(config.degraded)
    while pending:
        for fid in pending:
            a = Upgrade(*fid)
            if not preconditions(system, config, a):
                steps.append(a)
                config = Configuration(config.components, config.degraded - {fid}, config.roles)
                pending.remove(fid)
                break
        else:
            raise NoSafePlan([f"cannot resume {', '.join(f'{c}.{f}' for c, f in pending)}"])
    return steps


def _falls_short(system: ir.System, role: tuple[str, str, str]) -> bool:
    """Whether `role` attaches an output whose degraded guarantee does not satisfy its connector."""
    conn, comp, port = role
    c, k = system.component(comp), system.connector(conn)
    if c is None or k is None or (c.port(port) or _NOPORT).kind != "output":
        return False
    return not any(f.degraded is not None and satisfies(f.degraded.guarantee(port), k.guarantee)
                   for f in c.functionalities if port in f.ports)


def _plan(old: ir.System, new: ir.System, old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo],
          strategy: str) -> Transition:
    hoods = _neighbourhoods(old, new, old_infos, new_infos)
    if not hoods:
        simple = _hand_over_first(plan_migrate(old, new, strategy), old_infos, new_infos, strategy)
        _watch(simple, old_infos, new_infos)
        return _refuse_lost_requests(Transition(simple, old, new, old_infos, new_infos, []))
    # The combined system, the target and the renames, from the cheapest planner that succeeds.
    try:
        plan = plan_migrate(old, new, "paper")
    except NoSafePlan:
        plan = plan_migrate(old, new, strategy)
    # Suspend, substitute and link with the protocols kept suspended, resume.
    system, start, final = plan.system, plan.states[0], plan.goal
    funcs = [_func(system, p) for p in sorted(hoods)]
    # a takeover would rebind what the plan moves: a duplex's crash detection is suspended with
    # its protocols (its alarm raised by a heartbeat the plan's own process starts delayed)
    funcs += [_func(system, d) for d in _detectors(old, new, old_infos, new_infos, hoods)]
    pre = _suspend_steps(system, start, funcs)
    mid = start
    for a in pre:
        assert isinstance(a, Degrade)
        mid = Configuration(mid.components, mid.degraded | {(a.component, a.functionality)}, mid.roles)
    # While the protocols are suspended, what depends on them is degraded too and cannot be linked
    # where its degraded guarantee falls short: those new outputs are linked after the resume.
    # Their old outputs stay linked until then, so whatever reads them (the proxy) keeps a publisher.
    keep = {r for r in start.roles - final.roles if r[1] in hoods
            and (system.component(r[1]) or _NOPORT).port(r[2]).kind == "output"}  # type: ignore[union-attr]
    late = _linked_after_resume(system, start, final, keep, funcs)
    middle, steps, end = _substitute_and_link(plan, old, old_infos, new_infos, mid, keep, late, funcs, strategy)
    steps, end = _link_before_resume(plan, hoods, late, steps, end, strategy)
    post = solve(Problem(system, end, final, renames=dict(plan.renames)), strategy).steps \
        if late or keep else _resume_steps(system, end)
    whole = _prepared(system, start, pre + steps + post, final, strategy, plan.renames, hoods)
    # what the middle part leaves degraded is only so while the protocols are suspended; the
    # whole plan's own residual notes say what stays degraded at the end
    passing = set(middle.goal.residual_notes())
    whole.notes = [f"suspended while their neighbourhood changes: {', '.join(sorted(hoods))}"] + whole.notes \
        + [n for n in middle.notes if n not in passing and n not in whole.notes and not n.startswith("verification:")]
    whole = _served_when_resumed(whole, old_infos, new_infos, hoods)
    problems = suspension_problems(whole, hoods)
    if problems:
        raise NoSafePlan(problems)
    _watch(whole, old_infos, new_infos)
    return _refuse_lost_requests(Transition(whole, old, new, old_infos, new_infos, sorted(hoods), presuspended=True))


def _served_when_resumed(plan: Plan, old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo],
                         hoods: dict[str, set[str]]) -> Plan:
    """`plan` with each served proxy's upgrade, and its clients', moved to where the proxy's
    requests reach the application again (`served`), where every precondition still holds and
    every protocol stays suspended while its neighbourhood changes; `plan` where they are there
    already, or cannot be. The model lets a client be normal once its proxy is, and the proxy
    once the reply path is linked, while a request path still being linked holds its requests:
    toward SEC(PBR(TR)) the client was upgraded 15 steps before the new SEC protocol's inward
    port was linked, and its monitor saw replies late in 10 of 10 runs at 50 requests/s."""
    system, start = plan.system, plan.states[0]
    pairs = serving(old_infos, new_infos)
    targets = targets_of(protocols(old_infos, new_infos))
    steps = list(plan.steps)
    for conn, proxy in pairs:
        ctx = _Served(system, proxy, {c for c, _ in pairs}, targets.get(proxy, set()))
        side = {proxy} | {c for k, c, _ in start.roles if k == conn and c != proxy}
        ups = [i for i, a in enumerate(steps) if isinstance(a, Upgrade) and a.component in side]
        if not ups:
            continue
        states = [start]
        for a in steps:
            states.append(effect(system, states[-1], a))
        ready = next((j for j in range(ups[0], len(steps)) if ctx.served(states[j + 1])), None)
        if ready is None or ready == ups[0]:
            continue
        moved = [steps[i] for i in ups if i < ready]
        rest = [a for i, a in enumerate(steps) if not (i in ups and i < ready)]
        at = ready + 1 - len(moved)
        cand = rest[:at] + moved + rest[at:]
        if cost(system, start, cand, plan.goal) is not None:
            steps = cand
    if steps == list(plan.steps):
        return plan
    again = verify(system, start, steps, plan.goal, plan.strategy, plan.renames)
    if suspension_problems(again, hoods):
        return plan
    again.notes = plan.notes + [n for n in again.notes if n not in plan.notes]
    return again


@dataclass
class _Served:
    """Whether a proxy's requests are served in a state: through the readers of what it publishes
    (not on its clients' connectors `clients`), past resumed protocols only (a suspended one
    queues), they reach a node that calls a service (a Proceed, calling the application), whose
    results reach the proxy back."""

    system: ir.System
    proxy: str
    clients: set[str]
    protocols: set[str]

    def served(self, state: Configuration) -> bool:
        st = Snapshot(catalogue(self.system), state)
        held = self.protocols & {c for c, _ in state.degraded}     # suspended: they hold what they are sent
        callers = [c for c in reached(st, self.proxy, self.clients, held) if self._calls(state, c)]
        return any(self.proxy in reached(st, c, self.clients) for c in callers)

    def _calls(self, state: Configuration, comp: str) -> bool:
        return any(c == comp and k not in self.clients and service_client(self.system, k, c, port)
                   for k, c, port in state.roles)


def _prepared(system: ir.System, start: Configuration, steps: list[Action], final: Goal, strategy: str,
              renames: dict[str, str], hoods: dict[str, set[str]]) -> Plan:
    """The verified plan of `steps`, its new nodes created before the suspension
    (checker.planning.prepare), where that keeps every protocol suspended while its
    neighbourhood changes; `steps` as they are for the paper's strategy, or where it does not.
    The creates move, and the steps that link the new nodes only among themselves (`isolated`):
    an input of a new node attached where an old node publishes let a new Proceed take the old
    path's requests to the application, which answered wrong from then on in 1 of 3 PBR(TR) ->
    PBR runs at 50 requests/s (docs/ftm.md#a-transition-under-load). At the end, the steps that
    take an old layer apart once it is cut off from what stays (`_cut_off`)."""
    if strategy != "paper":
        ordered = prepare_first(system, start, steps, final, durations(system), isolated=True)
        if ordered is not steps:
            whole = verify(system, start, ordered, final, strategy, renames)
            if not suspension_problems(whole, hoods):
                return whole
    return verify(system, start, steps, final, strategy, renames)


def _neighbourhoods(old: ir.System, new: ir.System, old_infos: list[ExpansionInfo],
                    new_infos: list[ExpansionInfo]) -> dict[str, set[str]]:
    """Every surviving protocol whose neighbourhood changes, with that neighbourhood."""
    hoods: dict[str, set[str]] = {}
    by_server = {i.server: i for i in new_infos}
    for oi in old_infos:
        ni = by_server.get(oi.server)
        if ni is not None:
            hoods.update(affected_protocols(old, new, oi, ni))
    return hoods


def _watch(plan: Plan, old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo]) -> None:
    """Tell `plan` which proxies must keep serving, and through which protocols."""
    plan.serving = serving(old_infos, new_infos)
    plan.handover = handover(old_infos, new_infos)
    plan.protocols = protocols(old_infos, new_infos)


def _linked_after_resume(system: ir.System, start: Configuration, final: Goal,
                         keep: set[tuple[str, str, str]], funcs: list[FuncId]) -> set[tuple[str, str, str]]:
    """The new roles of nodes left degraded by the suspension whose degraded guarantee falls
    short of their connector: they wait for the resume."""
    late: set[tuple[str, str, str]] = set()
    while True:
        settled = settle(system, Goal(final.components, (final.roles - late) | keep, frozenset(funcs)))
        down = {c for c, _ in settled.degraded}
        more = {r for r in final.roles - start.roles if r[1] in down and _falls_short(system, r)} - late
        if not more:
            return late
        late |= more


def _substitute_and_link(plan: Plan, old: ir.System, old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo],
                         mid: Configuration, keep: set[tuple[str, str, str]], late: set[tuple[str, str, str]],
                         funcs: list[FuncId], strategy: str) -> tuple[Plan, list[Action], Configuration]:
    """The middle part, with the protocols suspended: substitute and link, keeping the old
    request path until the new one is linked, then unlink it. Returns the middle plan, its
    steps (with the unlinking) and the state they end in."""
    system, start, final = plan.system, plan.states[0], plan.goal
    # The proxies' old request path stays too (their request outputs, and the suspended
    # protocols' inputs reading them), so requests reach a protocol, which queues them,
    # until the new path is linked; it is unlinked then, before the resume.
    path, through = _request_path(system, start, old_infos, new_infos)
    switch = path - final.roles
    stay = sorted(through - final.components) if switch else []
    kept = Goal(final.components | frozenset(stay), (final.roles - late) | keep | switch, frozenset(funcs))
    olds = {c.name for c in old.components}
    replaced = [(plan.renames[n], n) for n in plan.renames if plan.renames[n] in olds and n in final.components]
    # in name order, not a set's: the plan must not depend on the interpreter's string hashing
    added = [n for n in sorted(final.components) if n not in olds and (n, n) not in replaced and n not in plan.renames]
    added += [n for n in plan.renames if plan.renames[n] not in olds and n in final.components]
    removed = [n for n in sorted(olds) if n not in final.components and n not in plan.renames.values()]
    middle = solve(Problem(system, mid, kept, replaced=replaced, removed=[n for n in removed if n not in stay],
                           added=added, renames=dict(plan.renames)), strategy)
    steps, end = middle.steps, middle.states[-1]
    if switch:
        unlinked = settle(system, Goal(final.components, (final.roles - late) | keep, frozenset(funcs)))
        moved = solve(Problem(system, end, unlinked, removed=stay, renames=dict(plan.renames)), strategy)
        steps, end = steps + moved.steps, moved.states[-1]
    return middle, steps, end


def _link_before_resume(plan: Plan, hoods: dict[str, set[str]], late: set[tuple[str, str, str]],
                        steps: list[Action], end: Configuration, strategy: str) -> tuple[list[Action], Configuration]:
    """`steps` and `end` extended by the links that waited for their node's resume, made while
    each protocol whose neighbourhood they are in stays suspended, if those nodes do not
    depend on it."""
    system, final = plan.system, plan.goal
    hold: set[FuncId] = set()
    for p, hood in sorted(hoods.items()):
        nodes = {r[1] for r in late if r[1] in hood or plan.renames.get(r[1], r[1]) in hood}
        if not nodes:
            continue
        held = settle(system, Goal(final.components, final.roles, frozenset({_func(system, p)})))
        if not any(c in nodes for c, _ in held.degraded):
            hold.add(_func(system, p))
    if not hold:
        return steps, end
    held = settle(system, Goal(final.components, final.roles, frozenset(hold)))
    down = {c for c, _ in held.degraded}
    roles = final.roles - {r for r in late if r[1] in down}
    linked = solve(Problem(system, end, settle(system, Goal(final.components, roles, frozenset(hold))),
                           renames=dict(plan.renames)), strategy)
    return steps + linked.steps, linked.states[-1]


def _detectors(old: ir.System, new: ir.System, old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo],
               hoods: dict[str, set[str]]) -> list[str]:
    """The crash detectors, kept by the transition, of the servers whose protocols it suspends."""
    by_server = {j.server: j for j in new_infos}
    return sorted(i.detector for i in old_infos if i.detector and any(p in hoods for p in i.protocols)
                  and i.server in by_server and by_server[i.server].detector == i.detector
                  and old.component(i.detector) == new.component(i.detector))


def _hand_over_first(plan: Plan, old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo],
                     strategy: str) -> Plan:
    """`plan` reordered so that a server losing its FTM first gets its clients back (their
    connector's publishers as in the target: the application instead of the proxy), and only
    then sees the mechanism taken down: until the hand-over the proxy's request path is whole,
    so no request is sent into a half-removed mechanism."""
    after = {j.server for j in new_infos}
    conns = {i.connector for i in old_infos if i.server not in after}
    if not conns or not plan.steps:
        return plan
    system, start, final = plan.system, plan.states[0], plan.goal
    onto = {r for r in final.roles if r[0] in conns}
    comps = {c for _, c, _ in onto}
    handed = settle(system, Goal(start.components | comps, (start.roles - {r for r in start.roles if r[0] in conns})
                                 | onto, start.degraded))
    first = solve(Problem(system, start, handed, added=sorted(comps - start.components),
                          renames=dict(plan.renames)), strategy)
    rest = solve(Problem(system, first.states[-1], final, removed=sorted(start.components - final.components),
                         renames=dict(plan.renames)), strategy)
    whole = verify(system, start, first.steps + rest.steps, final, strategy, plan.renames)
    whole.notes = plan.notes + [n for n in whole.notes if n not in plan.notes]
    return whole


def _request_path(system: ir.System, start: Configuration, old_infos: list[ExpansionInfo],
                  new_infos: list[ExpansionInfo]) -> tuple[set[tuple[str, str, str]], set[str]]:
    """The roles and components that carry each served proxy's requests to a protocol in
    `start` (up to the first protocols reached): the planner keeps them until the new path
    is linked."""
    targets = targets_of(protocols(old_infos, new_infos))
    st = Snapshot(catalogue(system), start)
    roles: set[tuple[str, str, str]] = set()
    comps: set[str] = set()
    for conn, proxy in serving(old_infos, new_infos):
        seen, frontier = {proxy}, [proxy]
        while frontier:
            comp = frontier.pop()
            for k, port in st.attached_outputs(comp):
                if k == conn:
                    continue
                for reader, into in st.subs.get(k, ()):
                    roles |= {(k, comp, port), (k, reader, into)}
                    if reader not in seen:
                        seen.add(reader)
                        if reader not in targets.get(proxy, set()):
                            frontier.append(reader)
        comps |= seen
    return roles, comps


def plan_transition(system: ir.System, component: str, new_ftm: Union[str, ir.FtmExpr, None],
                    hosts: Optional[tuple[str, ...]] = None, strategy: str = "default",
                    allow_invalid: bool = True) -> Transition:
    """Plan the change of `component`'s FTM to `new_ftm` (None: remove it) in `system`. Unless
    `allow_invalid`, a new FTM that the component's (F, A, R) rules out (an FTM rule the target
    breaks, RC401-RC407, as `reconf check` judges it) is refused: FtmRuleBroken, with the rules."""
    expr = parse_ftm(new_ftm) if isinstance(new_ftm, str) else new_ftm
    target = with_ftm(system, component, expr, hosts)
    if not allow_invalid:
        refuse_invalid_ftm(target, component, expr)
    old, old_infos = expand(system)
    new, new_infos = expand(target)
    return _with_rule_notes(_plan(old, new, old_infos, new_infos, strategy), target, {component})


def refuse_invalid_ftm(target: ir.System, component: str, expr: Optional[ir.FtmExpr]) -> None:
    """Raise FtmRuleBroken when `target` breaks an FTM rule on `component` (its errors, named)."""
    # RC401 (an ill-formed expression) is the user's typing, bad input: not judged here
    broken = [d for d in ftm_diagnostics(target, {component}) if d.is_error and d.code != "RC401"]
    if broken:
        note = (f"the FTM rules rule {expr if expr is not None else 'none'} out for {component}; "
                "--allow-invalid-ftm plans the transition anyway")
        raise FtmRuleBroken([dc_replace(d, notes=d.notes + (note,)) for d in broken])


def plan_ftm_migrate(old_system: ir.System, new_system: ir.System, strategy: str = "default") -> Transition:
    """`reconf plan migrate` for architectures with FTMs: both expanded, then migrated."""
    old, old_infos = expand(old_system)
    new, new_infos = expand(new_system)
    changed = {c.name for c in new_system.components
               if (c.ftm, c.faults, c.application, c.resources) != _declared(old_system, c.name)}
    return _with_rule_notes(_plan(old, new, old_infos, new_infos, strategy), new_system, changed)


def _declared(system: ir.System, name: str) -> tuple[object, ...]:
    """What `name` declares about fault tolerance in `system` (its FTM and (F, A, R))."""
    c = system.component(name)
    return (None, None, None, None) if c is None else (c.ftm, c.faults, c.application, c.resources)


def _with_rule_notes(t: Transition, target: ir.System, only: Optional[set[str]] = None) -> Transition:
    """`t` with a warning for every FTM rule (RC402–RC407) the target architecture breaks: the
    plan is safe, but the mechanism it moves to does not hold under the component's declared
    faults, characteristics or resources (`reconf check` reports the same as errors)."""

    for d in ftm_diagnostics(target, only):
        t.plan.notes.append(f"warning: the target breaks an FTM rule: {d.code} {d.message}")
    return t


def serving(old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo]) -> list[tuple[str, str]]:
    """(client-facing connector, proxy) of every server protected before and after whose
    mechanism changes: these must serve their clients in every state of the transition
    (`Plan.serving`). Servers whose expansion stays as it is are untouched by the plan."""
    after = {j.server: j for j in new_infos}
    return [(i.connector, i.proxy) for i in old_infos if i.server in after
            and (i.composition, sorted(i.components)) != (after[i.server].composition, sorted(after[i.server].components))]


def handover(old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo]) -> list[tuple[str, str]]:
    """(client-facing connector, proxy) of every server that loses its FTM or gains one: while
    the proxy publishes on the connector, it must serve (`Plan.handover`)."""
    before, after = {i.server for i in old_infos}, {j.server for j in new_infos}
    return [(i.connector, i.proxy) for i in old_infos if i.server not in after] + \
        [(j.connector, j.proxy) for j in new_infos if j.server not in before]


def protocols(old_infos: list[ExpansionInfo], new_infos: list[ExpansionInfo]) -> list[tuple[str, str]]:
    """(proxy, protocol) for every proxy a transition must keep serving (`serving`, `handover`)
    and every protocol, old or new, of its server: the proxy's requests must reach one of
    them (`Plan.protocols`)."""
    watched = {proxy for _, proxy in serving(old_infos, new_infos) + handover(old_infos, new_infos)}
    infos = old_infos + new_infos
    return sorted({(i.proxy, p) for i in infos if i.proxy in watched
                   for j in infos if j.server == i.server for p in j.protocols})


def reaches_protocol(system: ir.System, state: Configuration, proxy: str, clients: set[str],
                     targets: set[str]) -> bool:
    """Whether, in `state`, the requests `proxy` publishes (on any connector but the clients'
    connectors `clients`) reach a present protocol of `targets`, through the readers of each
    connector and what those publish (a suspended protocol queues them)."""
    return reaches(Snapshot(catalogue(system), state), proxy, clients, targets)


def _refuse_lost_requests(t: Transition) -> Transition:
    """`t`, unless a request could be lost in one of its states (`request_problems`)."""
    problems = request_problems(t.plan)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise NoSafePlan([f"a client request could be lost: {problems[0]}{more}"])
    return t


def client_side_ok(t: Transition) -> list[str]:
    """For every server protected before and after: every state in which its proxy is absent,
    or its clients' connector unsatisfied (its clients degraded) in more than one run of states
    (the clients wait once, for the suspension); and every state in which a request could be
    lost (`request_problems`)."""
    out = request_problems(t.plan)
    evs = [evaluate(t.plan.system, st, explain=False) for st in t.plan.states]
    for i in t.old_infos:
        if not any(j.server == i.server for j in t.new_infos):
            continue
        down = [k for k, ev in enumerate(evs) if not ev.connectors.get(i.connector, False)]
        out += [f"state {k}: {i.proxy} is absent" for k, st in enumerate(t.plan.states) if i.proxy not in st.components]
        if down and down != list(range(down[0], down[-1] + 1)):
            gap = next(k for k in range(down[0], down[-1]) if k not in down)
            out.append(f"state {gap}: {i.connector} is satisfied between two runs of states where it is not")
    return out
