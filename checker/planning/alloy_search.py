"""Alloy as a second planner: a reconfiguration found as an Alloy 6 trace.

The module (codegen/templates/alloy/planner.als.j2) holds the architecture as `fun`
constants, exactly the atoms and constants of an instance module, and the configuration
as `var` fields of one System atom. The semantics are the shared ones (semantics.j2) and
the six actions are the meta-model's (actions.j2), read over the current state and the
next one. A trace starts in `problem.start`, takes one action per step while the goal
does not hold and stays put once it does, and every state is valid.

Search, for `max_steps` steps at most:
1. with no bound on disruption: the analyzer tries traces from the shortest up, so the
   first plan has the fewest steps;
2. then with `disruption <= d - 1`, d that of the last plan, until no plan exists. Each plan
   found is again the shortest within its bound, so the last one is the least disruptive
   of at most `max_steps` steps, and among those the shortest: the order of the
   `exhaustive` strategy (disruption, then steps).

Traces start at a lower bound on the steps (each differing attachment, component and mode
takes a step of its own) and, once a plan is found, at its length.

Disruption (checker.planning.plan.disruption) is an integer sum over the states; the
module keeps a running total `spent` as a `var` Int, with a bit width that holds the bound
plus one state's weight: a trace whose total goes beyond is over the bound anyway, and
the analyzer (overflow forbidden) discards it. Decoded plans are costed again in Python.

Configurations are read in Alloy as in the meta-model: every functionality of an absent
component counts as degraded. Decoded plans use the Python engine's configurations again.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Iterable, Optional

import codegen.alloy as gen
from checker.alloy.bridge import DEFAULT_SOLVER, Backend, atom_name, get_backend
from checker.alloy.errors import AlloyError
from checker.planning.plan import Goal, NoSafePlan, Plan, Problem, disruption, ready, verify
from checker.semantic_model.actions import Action, catalogue, changes
from checker.semantic_model.config import Configuration
from codegen.alloy_module import PlannerModule, StateTerms
from reconf_dsl.ir import Component, System
from reconf_dsl.words import plural

__all__ = ["AlloySearch", "Solve", "alloy_plan", "alloy_search", "plan_with_alloy", "render_planner"]

MAIN = "planner.als"
STRATEGY = "alloy"


# -- Rendering --------------------------------------------------------------------------

def _two_state_actions() -> str:
    """The six actions of actions.j2, over the current state `s` and the next one: `s2.x`
    becomes `(s.x)'` and `s2` leaves every parameter list."""
    text = gen.render_actions(gen.PLAN_STATE)
    text = text.replace("[s, s2: System", "[s: System").replace("[s, s2,", "[s,").replace("[s, s2]", "[s]")
    text = re.sub(r"\bs2\.(\w+)", r"(s.\1)'", text)
    if any(re.search(r"\bs2\b", line.split("--")[0]) for line in text.splitlines()):
        raise AlloyError("actions.j2 names the next state in a way the planner cannot translate")
    return text


def _all_components(system: System) -> list[Component]:
    names = {c.name for c in system.components}
    return list(system.components) + [v for v in system.versions if v.name not in names]


def _alloy_degraded(system: System, components: Iterable[str], degraded: Iterable[tuple[str, str]]) -> set[tuple[str, str]]:
    """Degraded functionalities as Alloy reads them: those of absent components too."""
    present = set(components)
    return set(degraded) | {(c.name, f.name) for c in _all_components(system) if c.name not in present
                            for f in c.functionalities}


def _bitwidth(top: int) -> int:
    """The least Alloy bit width (two's complement) that holds 0..top."""
    bits = 2
    while (1 << (bits - 1)) - 1 < top:
        bits += 1
    return bits


def render_planner(problem: Problem, max_steps: int = 12, bound: Optional[int] = None,
                   module_name: str = "planner", min_steps: int = 0) -> tuple[str, dict[str, tuple[str, ...]]]:
    """The planning module for `problem` (its goal settled), traces of `min_steps` to
    `max_steps` steps, and with `bound` a bound on disruption; and the map from atom to
    DSL name."""
    system, start, goal = problem.system, problem.start, problem.goal
    arch = gen.describe_architecture(system)
    atom = arch.atoms()
    cat = catalogue(system)

    def comps(cs: Iterable[str]) -> str:
        return gen.union([atom["component", c] for c in sorted(cs)], "none")

    def funcs(fs: Iterable[tuple[str, str]]) -> str:
        return gen.union([atom["functionality", c, f] for c, f in sorted(fs)], "none")

    def roles(rs: Iterable[tuple[str, str, str]]) -> str:
        return gen.union([f"{atom['connector', k]} -> {atom['port', c, p]}" for k, c, p in sorted(rs)],
                         "(Connector -> Port - Connector -> Port)")

    all_funcs = [(c.name, f.name) for c in _all_components(system) for f in c.functionalities]
    crit = gen.union([f"{atom['functionality', c, f]} -> {cat.funcs[c, f].criticality}" for c, f in all_funcs],
                     "(Functionality -> Int - Functionality -> Int)")
    total = sum(cat.funcs[d].criticality for d in all_funcs)
    start_weight = sum(cat.funcs[d].criticality for d in start.degraded if d[0] in start.components)
    # Room for the bound plus the start's weight plus one state's weight. A trace whose
    # running total goes beyond is over the bound anyway (weights are not negative), and
    # with overflow forbidden the analyzer discards it; decoded plans are re-costed.
    bitwidth = _bitwidth((bound or 0) + start_weight + total) if bound is not None else 4
    module = PlannerModule(
        module_name, system.name, arch, _two_state_actions(), crit, bound, start_weight, bitwidth,
        states=max_steps + 1, min_states=min(min_steps, max_steps) + 1,
        start=StateTerms(comps(start.components), roles(start.roles),
                         funcs(_alloy_degraded(system, start.components, start.degraded))),
        goal=StateTerms(comps(goal.components), roles(goal.roles), funcs(goal.degraded)))
    return gen.render_planner_module(module), arch.names


# -- Solving and decoding -----------------------------------------------------------------

def _solve(text: str, names: dict[str, tuple[str, ...]], solver: str,
           bridge: Backend) -> tuple[Optional[list[Configuration]], float]:
    """Run the module's one command; the trace's configurations (up to its loop), or None
    when there is no plan; and the solving time."""
    trace = bridge.solve_module(text, MAIN, ("System.comps", "System.degraded", "System.roles"), 0, solver)
    if not trace.satisfiable:
        return None, trace.seconds

    def value(state: dict[str, set[tuple[str, ...]]], expr: str) -> set[tuple[str, ...]]:
        return {tuple(atom_name(a) for a in t) for t in state[expr]}

    states = []
    for state in trace.states:
        components = frozenset(names[a][1] for (a,) in value(state, "System.comps"))
        degraded = frozenset((names[a][1], names[a][2]) for (a,) in value(state, "System.degraded")
                             if names[a][1] in components)
        roles = frozenset((names[k][1], names[p][1], names[p][2]) for k, p in value(state, "System.roles"))
        states.append(Configuration(components, degraded, roles))
    return states, trace.seconds


def _action(before: Configuration, after: Configuration) -> Action:
    """The action that takes `before` to `after` (one step of a trace)."""
    found = changes(before, after)
    if len(found) != 1:
        raise AlloyError(f"a step of the Alloy trace is not one action: {[a.describe() for a in found]}")
    return found[0]


def _steps(system: System, states: list[Configuration], goal: Goal) -> list[Action]:
    steps: list[Action] = []
    for before, after in zip(states, states[1:]):
        if goal.reached(before):
            break
        steps.append(_action(before, after))
    return steps


@dataclass(frozen=True)
class Solve:
    """One analyzer run: the disruption bound (None: unbounded), whether a plan was found,
    its steps and disruption, and the seconds the solver took."""

    bound: Optional[int]
    found: bool
    steps: int
    disruption: int
    seconds: float


@dataclass
class AlloySearch:
    """What `alloy_search` found: the steps, their disruption, every run, and whether the
    plan is shown least disruptive among plans of at most `max_steps` steps."""

    steps: list[Action]
    disruption: int
    max_steps: int
    optimal: bool
    solves: list[Solve] = field(default_factory=list)

    @property
    def seconds(self) -> float:
        return sum(s.seconds for s in self.solves)

    def note(self) -> str:
        scope = f"among plans of at most {plural(self.max_steps, 'step')}"
        return (f"alloy: least disruptive {scope}, then fewest steps ({plural(len(self.solves), 'solve')}, "
                f"{self.seconds:.1f} s)")


def _fewest_steps(problem: Problem) -> int:
    """A lower bound on the steps of any plan: every attachment, component and mode that
    differs between start and goal takes a step of its own (a created component's
    functionalities start degraded)."""
    system, start, goal = problem.system, problem.start, problem.goal
    cat = catalogue(system)
    staying = start.components & goal.components
    arriving = [(c, f.name) for c in goal.components - start.components for f in cat.comps[c].functionalities]
    modes = {d for d in start.degraded ^ goal.degraded if d[0] in staying}
    return (len(start.roles ^ goal.roles) + len(start.components ^ goal.components) + len(modes)
            + len([d for d in arriving if d not in goal.degraded]))


def alloy_search(problem: Problem, max_steps: int = 12, solver: str = DEFAULT_SOLVER,
                 bridge: Optional[Backend] = None, minimise: bool = True) -> AlloySearch:
    """Plan `problem` (its goal settled, see `plan_with_alloy`) in Alloy; see the module
    docstring. Raises NoSafePlan when no plan of at most `max_steps` steps exists."""

    system, start, goal = problem.system, problem.start, problem.goal
    if goal.reached(start):
        return AlloySearch([], 0, max_steps, True)
    bridge = bridge or get_backend()
    solves: list[Solve] = []
    best: Optional[list[Action]] = None
    best_cost = 0
    bound: Optional[int] = None
    fewest = _fewest_steps(problem)  # then: no plan is shorter than the first one found
    while True:
        text, names = render_planner(problem, max_steps, bound, min_steps=fewest)
        states, seconds = _solve(text, names, solver, bridge)
        if states is None:
            solves.append(Solve(bound, False, 0, 0, seconds))
            break
        steps = _steps(system, states, goal)
        cost = disruption(system, states[:len(steps) + 1])
        solves.append(Solve(bound, True, len(steps), cost, seconds))
        if bound is not None and cost > bound:
            raise AlloyError(f"the Alloy plan's disruption {cost} exceeds its bound {bound}")
        best, best_cost = steps, cost
        fewest = max(fewest, len(steps))
        if not minimise or cost == 0:
            break
        bound = cost - 1
    if best is None:
        raise NoSafePlan([f"alloy: no safe plan of at most {plural(max_steps, 'step')} reaches the goal"])
    return AlloySearch(best, best_cost, max_steps, minimise, solves)


def alloy_plan(problem: Problem, max_steps: int = 12, solver: str = DEFAULT_SOLVER) -> list[Action]:
    """The steps of a least disruptive plan of at most `max_steps` steps for `problem`
    (goal settled), found in Alloy; the caller re-verifies them (`plan.verify`)."""
    return alloy_search(problem, max_steps, solver).steps


def plan_with_alloy(problem: Problem, max_steps: int = 12, solver: str = DEFAULT_SOLVER) -> Plan:
    """Plan `problem` in Alloy and check the result step by step with the Python engine;
    the same checks of the start and the target as `operations.solve` come first."""

    problem = ready(problem)
    search = alloy_search(problem, max_steps, solver)
    plan = verify(problem.system, problem.start, search.steps, problem.goal, STRATEGY, problem.renames)
    plan.notes.append(search.note())
    return plan
