"""The Alloy verdict on one configuration of a concrete architecture."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .bridge import DEFAULT_SOLVER, AlloyBridge
from .errors import AlloyError
from .spans import with_span

MAIN = "instance.als"


@dataclass(frozen=True)
class AlloyVerdict:
    """`valid` as Alloy judges it; `unsatisfied` lists (component, functionality,
    assumption index) of every assumption that does not hold, sorted."""

    valid: bool
    unsatisfied: tuple[tuple[str, str, int], ...]
    seconds: float
    text: str  # the instance module, for reports and golden files


def _atom(name: str) -> str:
    name = name.split("/")[-1]
    return name[:-2] if name.endswith("$0") else name


def alloy_verdict(system: Any, config: Any, solver: str = DEFAULT_SOLVER,
                  bridge: AlloyBridge | None = None) -> AlloyVerdict:
    """Judge `config` (checker.config.Configuration) of `system` (reconf_dsl.ir.System)
    in Alloy, through an instance module rendered from the shared semantics."""
    from codegen.alloy import render_instance

    text, names = render_instance(system, config)
    bridge = bridge or AlloyBridge.get()
    try:
        # `check Valid` first: over constants the solver folds `valid` to true or false
        # while translating, so a valid configuration costs no evaluation at all; only a
        # counterexample is asked which assumptions fail.
        (outcome,) = bridge.run({MAIN: text}, MAIN, "Valid", solver)
    except AlloyError as err:
        raise with_span(err, text, names, system) from None
    valid = not outcome.satisfiable
    pairs = set() if valid else outcome.eval("unsatisfied")
    failing: set[tuple[str, str, int]] = set()
    for f_atom, a_atom in pairs:
        _, comp, func = names[_atom(f_atom)]
        component = system.component(comp)
        functionality = next(f for f in component.functionalities if f.name == func)
        want = _atom(a_atom)
        for index, a in enumerate(functionality.normal.assumptions):
            if _data_atom(a, text, names) == want:
                failing.add((comp, func, index))
    return AlloyVerdict(valid, tuple(sorted(failing)), outcome.elapsed, text)


def _data_atom(pred: Any, text: str, names: dict[str, tuple[str, ...]]) -> str:
    if pred.message is None:
        return "Nothing"
    key = ("data", pred.message, "" if pred.hz is None else str(pred.hz))
    for atom, meaning in names.items():
        if meaning == key:
            return atom
    return ""


ACTIONS = ("remove", "create", "detach", "attach", "degrade", "upgrade")
PLAN_MAIN = "plan.als"


@dataclass(frozen=True)
class AlloyPlanVerdict:
    """Alloy's judgement of a plan: `valid[i]` for each configuration, and for each step i
    (configuration i to i+1) the action it performs when that action's pre/post-conditions
    hold (empty when they do not, or when the step is not a single action)."""

    valid: tuple[bool, ...]
    steps: tuple[tuple[str, ...], ...]
    seconds: float
    text: str

    @property
    def ok(self) -> bool:
        return all(self.valid) and all(self.steps)


def alloy_plan_verdict(system: Any, configs: list[Any], solver: str = DEFAULT_SOLVER,
                       bridge: AlloyBridge | None = None) -> AlloyPlanVerdict:
    """Check a plan (its successive configurations, initial first) in Alloy: each
    configuration valid, each step one of the six actions with its preconditions met."""
    from codegen.alloy import render_plan

    text, names = render_plan(system, configs)
    bridge = bridge or AlloyBridge.get()
    try:
        (outcome,) = bridge.run({PLAN_MAIN: text}, PLAN_MAIN, "Verdict", solver)
    except AlloyError as err:
        raise with_span(err, text, names, system) from None
    n = len(configs)
    valid_states = {_atom(s) for (s,) in outcome.eval("valid_states")}
    did: dict[str, set[str]] = {}
    for s, a in outcome.eval("ok_steps"):
        did.setdefault(_atom(s), set()).add(_atom(a).lower())
    valid = tuple(f"S{i}" in valid_states for i in range(n))
    steps = [tuple(a for a in ACTIONS if a in did.get(f"S{i}", set())) for i in range(n - 1)]
    return AlloyPlanVerdict(valid, tuple(steps), outcome.elapsed, text)
