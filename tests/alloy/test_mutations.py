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
from checker.alloy.verify_meta_model import counterexample

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
    ("attach.single", "KeepsSingle", "attach "),
    ("attach.service", "KeepsOneServer", "attach "),
    ("attach.present", "KeepsOwned", "attach "),
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
    connector its degraded guarantee satisfied, unless upgrade.connectors (the Python
    engine's check of the same) refuses it."""
    text = metamodel_modules(SCOPE)[MAIN]
    start = text.index("fact degraded_weaker {")
    end = text.index("}\n", start) + 2
    modules = {MAIN: text[:start] + text[end:]}
    (outcome,) = bridge.run(modules, MAIN, "SafeUpgrade")
    assert not outcome.satisfiable
    (outcome,) = bridge.run({MAIN: without(modules[MAIN], "upgrade.connectors")}, MAIN, "SafeUpgrade")
    assert outcome.satisfiable
    # and a recovery's prefix may then mend by degrading (one more degraded satisfies more)
    (outcome,) = bridge.run(modules, MAIN, "RecoverMonotone")
    assert outcome.satisfiable


# A plausible slip in each join encoding of a quantified precondition (plan modules use the
# joins): the assertion that it agrees with the quantifiers finds it.
ENCODING_SLIPS = [
    ("DetachInputEncodingsAgree", "no failing_no_role[s, (s.comps & inputs.p).funcs, k -> p]",
     "no failing_no_role[s, (s.comps & inputs.p).funcs, k -> Input]"),
    ("DetachOutputEncodingsAgree", "no failing_no_role[s, (s.comps & inputs.(k.(s.roles))).funcs, k -> Input]",
     "no failing_no_role[s, (s.comps & inputs.(k.(s.roles))).funcs, none -> none]"),
    ("AttachOutputEncodingsAgree", "k.cguar in p.(out_guar[s]).(Sem.sat)", "k.cguar in p.(Functionality.nguar)"),
    ("DegradeEncodingsAgree", "no failing_no_role[s, (s.comps & inputs.(aff.(s.roles))).funcs - f, aff -> Input]",
     "no failing_no_role[s, (s.comps & inputs.(aff.(s.roles))).funcs, aff -> Input]"),
    ("UpgradeEncodingsAgree", "f.nasms in (f.assoc_in & (s.isat)).iasm.(Sem.sat) + envg.(Sem.sat)",
     "f.nasms in f.assoc_in.iasm.(Sem.sat) + envg.(Sem.sat)"),
]


@pytest.mark.parametrize("assertion,right,slip", ENCODING_SLIPS, ids=[s[0] for s in ENCODING_SLIPS])
def test_encoding_slip_is_caught(bridge: AlloyBridge, assertion: str, right: str, slip: str) -> None:
    text = metamodel_modules(SCOPE)[MAIN]
    assert text.count(right) == 1, f"{right!r} not found exactly once"
    (outcome,) = bridge.run({MAIN: text.replace(right, slip)}, MAIN, assertion)
    assert outcome.satisfiable, f"{assertion} missed {slip!r}"
    (intact,) = bridge.run({MAIN: text}, MAIN, assertion)
    assert not intact.satisfiable
