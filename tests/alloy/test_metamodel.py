"""The meta-model: rendered from the shared macros, every run has an instance and every
safety assertion holds at a small scope."""
from __future__ import annotations

import pytest

from checker.alloy import AlloyBridge, CommandOutcome, metamodel_modules
from checker.alloy.metamodel import MAIN, committed_metamodel
from codegen.alloy import render_metamodel, render_semantics

ACTIONS = ["Remove", "Create", "Detach", "Attach", "Degrade", "Upgrade"]
SCOPE = 3


def test_committed_metamodel_is_the_rendering() -> None:
    assert committed_metamodel() == render_metamodel(), "run: python -m codegen.alloy --regenerate"


def test_semantics_come_from_one_source() -> None:
    text = committed_metamodel()
    for name in ("pred satisfy[", "pred valid[", "pred asm_holds[", "fun sat_inputs_def["):
        assert text.count(name) == 1
        assert name.rstrip("[") in render_semantics()


@pytest.fixture(scope="module")
def outcomes(bridge: AlloyBridge) -> dict[str, CommandOutcome]:
    return {o.label: o for o in bridge.run(metamodel_modules(SCOPE), MAIN)}


def test_every_action_has_a_check_and_a_run(outcomes: dict[str, CommandOutcome]) -> None:
    for action in ACTIONS:
        assert outcomes[f"Safe{action}"].is_check
        assert outcomes[f"Safe{action}"].expects == 0
        assert not outcomes[action].is_check
        assert outcomes[action].expects == 1


@pytest.mark.parametrize("action", ACTIONS)
def test_action_is_safe(outcomes: dict[str, CommandOutcome], action: str) -> None:
    o = outcomes[f"Safe{action}"]
    assert o.scope.startswith(str(SCOPE))
    assert not o.satisfiable and o.as_expected


@pytest.mark.parametrize("action", ACTIONS)
def test_action_preconditions_can_hold(outcomes: dict[str, CommandOutcome], action: str) -> None:
    o = outcomes[action]
    assert o.satisfiable and o.as_expected
    # both configurations are valid in the instance
    assert o.eval("Pre") and o.eval("Post")
    assert o.eval("{ s: System | valid[s] }") == o.eval("System")


def test_attach_keeps_connections_well_typed(outcomes: dict[str, CommandOutcome]) -> None:
    assert outcomes["AttachWellTyped"].as_expected


def test_absent_components_stay_degraded(bridge: AlloyBridge, outcomes: dict[str, CommandOutcome]) -> None:
    """The invariant that lets Alloy read Python configurations (no modes for absent
    components): it holds, and it needs remove to degrade what it removes."""
    assert outcomes["AbsentDegraded"].is_check and outcomes["AbsentDegraded"].as_expected
    text = metamodel_modules(SCOPE)[MAIN]
    assert text.count("s2.degraded = s.degraded + c.funcs") == 1
    mutated = text.replace("s2.degraded = s.degraded + c.funcs", "s2.degraded = s.degraded")
    (o,) = bridge.run({MAIN: mutated}, MAIN, "AbsentDegraded")
    assert o.satisfiable
