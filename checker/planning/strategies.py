"""The planning strategies, one registry: each a name, the function that finds its steps, and a
line on what it does. `solve` plans with one of them; the CLI's `--strategy` choices, the gate
policy's `strategy`, and the order of the fallback chain (`checker.planning.chain.CHAIN`) are
read from `STRATEGIES` (docs/architecture.md, "A planning strategy")."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from checker.planning.default import default_steps
from checker.planning.durations import degraded_seconds, durations
from checker.planning.exhaustive import Budget, exhaustive_search
from checker.planning.improve import cost, improve
from checker.planning.paper import paper_steps
from checker.planning.plan import NoSafePlan, Plan, Problem, ready, verify
from checker.planning.prepare import prepare_first
from checker.semantic_model.actions import Action

Steps = tuple[list[Action], Optional[str]]     # the steps, and a note on how they were found


@dataclass(frozen=True)
class Strategy:
    name: str
    # for a problem whose goal is settled (`ready`), the strategies already tried on it that found
    # no plan or one the caller refused (`checker.planning.chain`): their work is not done again
    steps: Callable[[Problem, Budget, frozenset[str]], Steps]
    summary: str


def _default(problem: Problem) -> tuple[list[Action], Optional[str]]:
    """The default strategy's order (`_default_order`), prepared first and cleaned up last
    (`checker.planning.prepare`) where that saves degraded seconds."""
    steps, note = _default_order(problem)
    system, start, goal = problem.system, problem.start, problem.goal
    times = durations(system)
    ordered = prepare_first(system, start, steps, goal, times)
    if ordered is steps:
        return steps, note
    was, now = (degraded_seconds(system, start, s, times).weighted for s in (steps, ordered))
    said = (f"prepared first, cleaned up last: the creates of new components and their inputs' attaches "
            f"before the first degrade, the removes after the last upgrade (~{was:.2f} s degraded → ~{now:.2f} s)")
    return ordered, (f"{note}; {said}" if note else said)


def _default_order(problem: Problem) -> tuple[list[Action], Optional[str]]:
    """The default strategy's plan, or the paper's (locally improved) when that is less disruptive."""
    system, start, goal = problem.system, problem.start, problem.goal
    reasons: list[str] = []
    mine: Optional[list[Action]] = None
    try:
        mine = default_steps(system, start, goal)
    except NoSafePlan as e:
        reasons += e.reasons
    try:
        theirs = paper_steps(problem)
    except NoSafePlan as e:
        if mine is None:
            raise NoSafePlan(reasons + e.reasons) from None
        return mine, None
    mine_cost = None if mine is None else cost(system, start, mine, goal)
    theirs_cost = cost(system, start, theirs, goal)
    if mine is not None and mine_cost is not None and (theirs_cost is None or mine_cost < theirs_cost):
        return mine, None
    theirs = improve(system, start, theirs, goal)
    improved = cost(system, start, theirs, goal)
    if mine is not None and mine_cost is not None and (improved is None or mine_cost <= improved):
        return mine, None
    return theirs, "the paper's order, improved, was less disruptive here and is kept"


def _paper(problem: Problem, budget: Budget, tried: frozenset[str]) -> Steps:
    return paper_steps(problem), None


def _exhaustive(problem: Problem, budget: Budget, tried: frozenset[str]) -> Steps:
    """The exhaustive search, started from the default strategy's plan where there is one: it
    returns nothing worse. After the default strategy failed (no plan, or one refused) there is
    none to start from, and the search starts from nothing instead of finding that again."""
    incumbent: Optional[list[Action]] = None
    if "default" not in tried:
        try:
            incumbent = _default(problem)[0]
        except NoSafePlan:
            pass
    search = exhaustive_search(problem.system, problem.start, problem.goal, budget, incumbent)
    return search.steps, search.note()


REGISTRY: dict[str, Strategy] = {s.name: s for s in (
    Strategy("default", lambda problem, budget, tried: _default(problem), "least disruption found"),
    Strategy("paper", _paper, "Algorithm 1 of paper 001"),
    Strategy("exhaustive", _exhaustive, "decides whether a plan exists, least disruptive where its budget allows"),
)}
STRATEGIES = tuple(REGISTRY)


def solve(problem: Problem, strategy: str = "default", budget: Budget = Budget(),
          tried: frozenset[str] = frozenset()) -> Plan:
    """Plan `problem` with `strategy` alone (`checker.planning.chain` goes on to the next
    strategy when one fails, and says which it `tried` before).

    `default` keeps the paper's plan, locally improved, when its own is not less disruptive,
    so it is never worse than `paper`; `budget` bounds the `exhaustive` search."""
    problem = ready(problem)
    if strategy not in REGISTRY:
        raise ValueError(f"unknown strategy {strategy!r}; choose one of {', '.join(STRATEGIES)}")
    steps, note = REGISTRY[strategy].steps(problem, budget, tried)
    plan = verify(problem.system, problem.start, steps, problem.goal, strategy, problem.renames)
    if note:
        plan.notes.append(note)
    return plan
