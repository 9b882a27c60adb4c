"""The plan executor's own copy of the semantics (`reconf_ros.executor.semantics.Model`: standard library
only, as plan scripts embed it) held to the checker's, on every example of the shared table and
on the configurations one and two actions away: the same failing assumptions, the same effect of
every action, and every action the checker's preconditions allow runs in the executor into a
configuration it finds valid (the proved Safe* theorems, on the executor's side)."""
from __future__ import annotations

from typing import Iterator

import pytest

from checker.semantic_model.actions import (
    Action,
    Attach,
    Create,
    Degrade,
    Detach,
    Remove,
    Upgrade,
    effect,
    preconditions,
)
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from codegen.ros2 import model_data
from reconf_dsl.ir import System
from reconf_dsl.loader import load
from reconf_ros.executor.plan_states import State
from reconf_ros.executor.semantics import Model
from reconf_ros.executor.steps import Step
from tests.examples_table import EXAMPLES

STATES_PER_EXAMPLE = 40


def _state(c: Configuration) -> State:
    return State(c.components, c.degraded, c.roles)


def _candidates(system: System, c: Configuration) -> Iterator[Action]:
    """Every action the shape of `c` suggests, allowed or not."""
    declared = {x.name: x for x in [*system.components, *system.versions]}
    for name, comp in sorted(declared.items()):
        if name not in c.components:
            yield Create(name)
            continue
        yield Remove(name)
        for f in comp.functionalities:
            yield Degrade(name, f.name) if (name, f.name) not in c.degraded else Upgrade(name, f.name)
        for port in comp.ports:
            for conn in system.connectors:
                role = (conn.name, name, port.name)
                yield Detach(*role) if role in c.roles else Attach(*role)


def _failing(system: System, c: Configuration) -> list[str]:
    return sorted(f"{r.component}.{r.functionality}" for r in evaluate(system, c).unsatisfied)


def _reached(system: System) -> list[Configuration]:
    """The deployed configuration and those reached from it by actions the checker allows,
    breadth first, at most STATES_PER_EXAMPLE."""
    seen, queue = [Configuration.initial(system)], [Configuration.initial(system)]
    while queue and len(seen) < STATES_PER_EXAMPLE:
        c = queue.pop(0)
        for a in _candidates(system, c):
            if not preconditions(system, c, a):
                nxt = effect(system, c, a)
                if nxt not in seen:
                    seen.append(nxt)
                    queue.append(nxt)
    return seen[:STATES_PER_EXAMPLE]


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e.name)
def test_the_executor_judges_as_the_checker(example) -> None:  # type: ignore[no-untyped-def]
    system = load([example.file])
    model = Model(model_data(system))
    configs = _reached(system)
    allowed = 0
    for c in configs:
        st = _state(c)
        assert sorted({f.split(" assumes ")[0] for f in model.failures(st)}) == sorted(set(_failing(system, c)))
        for a in _candidates(system, c):
            step = Step.from_doc(a.to_dict())
            after = effect(system, c, a)
            assert model.effect(st, step).key() == _state(after).key(), a.describe()
            if not preconditions(system, c, a):
                allowed += 1
                assert model.refusal(st, step) is None, a.describe()
                if not _failing(system, c):
                    assert model.failures(model.effect(st, step)) == [], a.describe()
    assert allowed > 0
