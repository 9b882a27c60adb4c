"""Plans made from bench's generated systems: replacing the hub of a shape, and a plan broken
in one state (for the Alloy plan-verification tests)."""
from __future__ import annotations

from dataclasses import replace as dc_replace

from bench.gen import generate, hub_component
from checker.planning import Plan, plan_replace
from checker.semantic_model.config import Configuration
from reconf_dsl.loader import load_text


def hub_plan(shape: str, n: int) -> Plan:
    system = load_text(generate(shape, n, 0, version=True), f"{shape}.arch")
    hub = hub_component(shape, n)
    return plan_replace(system, hub, hub + "_v2")


def break_state(plan: Plan, index: int) -> Plan:
    """The plan with every connector detached in state `index`: no step leads there."""
    states = list(plan.states)
    s = states[index]
    states[index] = Configuration(s.components, s.degraded, frozenset())
    return dc_replace(plan, states=states)
