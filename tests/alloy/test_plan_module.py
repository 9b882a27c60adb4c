"""Plan modules: the states of a plan judged by the meta-model's semantics and actions."""
from __future__ import annotations

import re

from checker.alloy import AlloyBridge, alloy_plan_verdict
from checker.alloy.metamodel import committed_metamodel
from checker.semantic_model.config import Configuration
from codegen.alloy import render_plan
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES

CHATTER = next(e for e in EXAMPLES if e.name == "chatter").file


def _chatter() -> tuple[object, Configuration, Configuration, Configuration]:
    system = load([CHATTER])
    c0 = Configuration.initial(system)
    listener = frozenset((c.name, f.name) for c in system.components if c.name == "listener"
                         for f in c.functionalities)
    talker_roles = frozenset(r for r in c0.roles if r[1] == "talker")
    c1 = Configuration(c0.components, c0.degraded | listener, c0.roles)
    c2 = Configuration(c1.components, c1.degraded, c1.roles - talker_roles)
    return system, c0, c1, c2


def test_degrade_then_detach_is_a_safe_plan(bridge: AlloyBridge) -> None:
    system, c0, c1, c2 = _chatter()
    verdict = alloy_plan_verdict(system, [c0, c1, c2], bridge=bridge)
    assert verdict.valid == (True, True, True)
    assert verdict.steps == (("degrade",), ("detach",))
    assert verdict.ok


def test_detach_before_degrade_is_refused(bridge: AlloyBridge) -> None:
    system, c0, _, c2 = _chatter()
    early = Configuration(c0.components, c0.degraded, c2.roles)
    verdict = alloy_plan_verdict(system, [c0, early], bridge=bridge)
    assert verdict.valid == (True, False)
    assert verdict.steps == ((),)  # the detach precondition fails
    assert not verdict.ok


def test_two_changes_are_not_one_step(bridge: AlloyBridge) -> None:
    system, c0, _, c2 = _chatter()
    verdict = alloy_plan_verdict(system, [c0, c2], bridge=bridge)
    assert verdict.valid == (True, True) and verdict.steps == ((),)


def test_plan_module_shares_the_actions_and_semantics() -> None:
    system, c0, c1, _ = _chatter()
    text, names = render_plan(system, [c0, c1])
    meta = committed_metamodel()
    # the dispatchers (valid, safe_no_input, ...) pick the join encodings in plan modules,
    # and the actions call the join encodings of their preconditions that quantify; the
    # definitions of both encodings are the meta-model's (whose satisfied connectors are
    # stored relations, computed in plan modules)
    for decl in ("pred detach[", "pred attach[", "pred degrade[", "pred upgrade[", "pred step[", "pred valid_q[",
                 "pred valid_j[", "pred safe_no_role_q[", "pred safe_no_role_j[", "fun failing_no_role[",
                 "fun degrade_aff[", "pred degrade_safe_q[", "pred degrade_safe_j[", "pred upgrade_holds_q["):
        block = meta[meta.index(decl):meta.index("\n}\n", meta.index(decl))]
        block = re.sub(r"\((s2?)\.csat\)", r"sat_conns_def[\1]", re.sub(r"_q\[s,", "_j[s,", block))
        assert block in text, decl
    assert names["S1"] == ("state", "1")
    assert "check PlanSafe" in text
