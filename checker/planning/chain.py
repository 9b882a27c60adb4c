"""The one entry point that plans with fallback: the strategies in turn, until one gives a plan
that is accepted.

    default → paper → exhaustive → alloy

starting at the strategy asked for. A strategy that finds no plan, gives up, or whose plan the
caller refuses (`Fallback.accept`: the Alloy Analyzer's verdict, say) hands over to the next.
The plan returned says which strategy produced it (`Plan.strategy`) and which were tried
before and why they failed (`Plan.attempts`). Only when every strategy failed is there no
plan: `NoPlanFound` then carries every attempt, and its reasons say the decisive one (the
exhaustive search decides whether a plan exists; see `checker.planning.exhaustive`).

The exhaustive search decides: when it proves that no plan exists, the chain stops there.
The Alloy planner (`checker.planning.alloy_search`) comes last, when the caller has Alloy
(`Fallback.alloy`) and the system is small, for what the exhaustive search could not decide
within its budget (or a plan of it that was refused): it searches traces of at most
`max_steps` steps, in which any port may be attached to any connector, in a worker process
stopped after `Fallback.alloy_seconds`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from checker.alloy.errors import AlloyUnavailable
from checker.planning.alloy_search import alloy_search
from checker.planning.exhaustive import Budget, Impossible, SearchTooLarge
from checker.planning.plan import Attempt, NoSafePlan, Plan, Problem, ready, verify
from checker.planning.strategies import STRATEGIES, solve

__all__ = ["CHAIN", "Attempt", "Fallback", "NoPlanFound", "plan_with_fallback"]

CHAIN = (*STRATEGIES, "alloy")      # the registry's order, then the Alloy planner

ALLOY_COMPONENTS = 40
"""Components (deployed and declared versions) beyond which the Alloy planner is not tried."""


@dataclass(frozen=True)
class Fallback:
    """How `plan_with_fallback` goes on. `accept` judges each plan found: None accepts it, a
    string says why it is refused (the next strategy is then tried). `alloy` ends the chain
    with the Alloy planner (plans of at most `max_steps` steps, within `alloy_seconds`).
    `budget` bounds the exhaustive search. `progress` is told which strategy runs. `shape`, when
    given, reorders each plan found (verified again, as checker.ftm.resume does) before `accept`
    judges it."""

    accept: Optional[Callable[[Plan], Optional[str]]] = None
    shape: Optional[Callable[[Plan], Plan]] = None
    alloy: bool = False
    max_steps: int = 12
    budget: Budget = field(default_factory=Budget)
    alloy_seconds: float = 120.0
    progress: Optional[Callable[[str], None]] = None


class NoPlanFound(NoSafePlan):
    """Every strategy failed; `attempts` says how each did."""

    def __init__(self, attempts: list[Attempt]) -> None:
        super().__init__([a.describe() for a in attempts])
        self.attempts = attempts


def _strategies(first: str, fallback: Fallback, problem: Problem) -> list[str]:
    if first not in CHAIN:
        raise ValueError(f"unknown strategy {first!r}; choose one of {', '.join(STRATEGIES)}")
    chain = list(CHAIN[CHAIN.index(first):])
    size = len(problem.system.components) + len(problem.system.versions)
    if "alloy" in chain and first != "alloy" and (not fallback.alloy or size > ALLOY_COMPONENTS):
        chain.remove("alloy")
    return chain


def _own(strategy: str, reasons: list[str]) -> tuple[str, ...]:
    """The reasons of `strategy` alone (the default strategy also reports the paper's, tried next)."""
    if strategy == "default":
        mine = [r for r in reasons if not r.startswith("paper: ")]
        return tuple(mine or reasons)
    return tuple(reasons)


class _Unavailable(Exception):
    """The Alloy planner cannot run here (no Java, no jar, no JPype)."""


def _alloy_work(out: Any, problem: Problem, max_steps: int) -> None:
    """In a worker process: the steps of the first Alloy plan, or why there is none."""
    try:
        out.put(("ok", alloy_search(problem, max_steps, minimise=False).steps))
    except NoSafePlan as e:
        out.put(("none", e.reasons))
    except AlloyUnavailable as e:
        out.put(("unavailable", str(e)))
    except BaseException as e:  # noqa: BLE001 - reported to the parent
        out.put(("error", f"{type(e).__name__}: {e}"))


def _alloy(problem: Problem, fallback: Fallback) -> Plan:
    """The Alloy planner's first plan, in a worker process stopped after `fallback.alloy_seconds`
    (a solve cannot be interrupted inside the JVM), checked step by step here."""
    import multiprocessing as mp
    import queue

    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    proc = ctx.Process(target=_alloy_work, args=(out, problem, fallback.max_steps), daemon=True)
    proc.start()
    try:
        kind, payload = out.get(timeout=fallback.alloy_seconds)
    except queue.Empty:
        proc.kill()
        proc.join(5)
        raise SearchTooLarge([f"alloy: no answer within {fallback.alloy_seconds:g} s"]) from None
    proc.join(10)
    if proc.is_alive():
        proc.kill()
    if kind == "none":
        raise NoSafePlan(list(payload))
    if kind == "unavailable":
        raise _Unavailable(payload)
    if kind != "ok":
        raise RuntimeError(f"the Alloy planner failed: {payload}")
    plan = verify(problem.system, problem.start, payload, problem.goal, "alloy", problem.renames)
    plan.notes.append(f"alloy: the first plan of at most {fallback.max_steps} steps the analyzer found "
                      "(not minimised)")
    return plan


def _run(problem: Problem, strategy: str, fallback: Fallback, attempts: list[Attempt]) -> Plan:
    if strategy == "alloy":
        return _alloy(problem, fallback)
    return solve(problem, strategy, fallback.budget, frozenset(a.strategy for a in attempts))


def plan_with_fallback(problem: Problem, strategy: str = "default", fallback: Fallback = Fallback()) -> Plan:
    """Plan `problem`, starting with `strategy` and going on along `CHAIN` (see the module
    docstring). Raises NoSafePlan when the start or the target is impossible (no strategy is
    tried), NoPlanFound when every strategy failed."""
    problem = ready(problem)
    attempts: list[Attempt] = []
    for name in _strategies(strategy, fallback, problem):
        if fallback.progress is not None:
            tried = ", ".join(a.strategy for a in attempts)
            fallback.progress(f"planning with the {name} strategy" + (f" ({tried}: no plan)" if tried else "") + "…")
        try:
            plan = _run(problem, name, fallback, attempts)
        except SearchTooLarge as e:
            attempts.append(Attempt(name, "gave up", tuple(e.reasons)))
            continue
        except Impossible as e:
            attempts.append(Attempt(name, "none exists", tuple(e.reasons), e.how))
            break       # decided: no plan exists (in the space its answer names)
        except NoSafePlan as e:
            attempts.append(Attempt(name, "no plan", _own(name, e.reasons)))
            continue
        except _Unavailable as e:
            attempts.append(Attempt(name, "unavailable", (str(e),)))
            continue
        if fallback.shape is not None:
            plan = fallback.shape(plan)
        refused = fallback.accept(plan) if fallback.accept is not None else None
        if refused:
            attempts.append(Attempt(name, "refuted", (refused,)))
            continue
        plan.attempts = list(attempts)
        return plan
    raise NoPlanFound(attempts)
