"""Each precondition is needed: delete it from the rendered meta-model and the action's
safety assertion gets a counterexample.

Precondition clauses are tagged `--@pre <action>.<name>` in the meta-model; a mutation
deletes one tagged line. Attaching only adds satisfaction (valid is monotone in the
roles), so attach's typing preconditions are shown needed for AttachWellTyped instead.
"""
from __future__ import annotations

import re

import pytest

from checker.alloy import AlloyBridge, metamodel_modules
from checker.alloy.metamodel import MAIN
from checker.verify_model import counterexample

SCOPE = 3

MUTATIONS = [
    ("remove.isolated", "SafeRemove", "remove "),
    ("create.degraded", "SafeCreate", "create "),
    ("detach.input", "SafeDetach", "detach "),
    ("detach.output", "SafeDetach", "detach "),
    ("degrade.safe", "SafeDegrade", "degrade "),
    ("upgrade.assumptions", "SafeUpgrade", "upgrade "),
    ("attach.output", "AttachWellTyped", "attach "),
    ("attach.input", "AttachWellTyped", "attach "),
]


def without(text: str, tag: str) -> str:
    pattern = re.compile(rf"^.*--@pre {re.escape(tag)}\s*$\n", re.MULTILINE)
    mutated, n = pattern.subn("", text)
    assert n == 1, f"precondition {tag} not found exactly once"
    return mutated


def test_every_tag_is_known() -> None:
    text = metamodel_modules(SCOPE)[MAIN]
    tags = set(re.findall(r"--@pre (\S+)", text))
    assert {m[0] for m in MUTATIONS} <= tags


@pytest.mark.parametrize("tag,assertion,action", MUTATIONS, ids=[m[0] for m in MUTATIONS])
def test_precondition_is_needed(bridge: AlloyBridge, tag: str, assertion: str, action: str) -> None:
    modules = {MAIN: without(metamodel_modules(SCOPE)[MAIN], tag)}
    (outcome,) = bridge.run(modules, MAIN, assertion)
    assert outcome.satisfiable, f"deleting {tag} left {assertion} without counterexample"
    cex = counterexample(outcome)
    assert cex.action.startswith(action)
    if assertion.startswith("Safe"):
        assert not cex.pre.unsatisfied and cex.post.unsatisfied


def test_degraded_mode_rule_is_needed(bridge: AlloyBridge) -> None:
    """Without rule (iii) (a degraded guarantee is never stronger), upgrading can break a
    connector its degraded guarantee satisfied."""
    text = metamodel_modules(SCOPE)[MAIN]
    start = text.index("fact degraded_weaker {")
    end = text.index("}\n", start) + 2
    modules = {MAIN: text[:start] + text[end:]}
    (outcome,) = bridge.run(modules, MAIN, "SafeUpgrade")
    assert outcome.satisfiable
