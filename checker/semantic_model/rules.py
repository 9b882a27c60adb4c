"""Every rule a configuration or a step must keep, written once: the one table that both
engines are held to.

The Python engine applies each rule by its name (`checker.semantic_model.actions`: a step's
preconditions and effect, `state_refusals` for a configuration); the Alloy templates carry
the same names as labels on the clauses that state them (`--@pre <action>.<rule>` and
`--@post <action>.effect` in `codegen/templates/alloy/actions.j2`, `--@rule state.<rule>` in
`semantics.j2`), so the meta-model, the instance evaluation and the plan evaluation all
apply them. `tests/test_rules.py` holds the names the Python code refuses by, the labels of
the templates and this table to one another, and plants each rule out of one engine in turn
to see the two engines' verdicts part (docs/soundness.md, "One list of rules").

A rule whose `witness` is not "" cannot be seen failing alone in the configurations both
engines read, and the text says why; the planted-rule test skips that side.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Rule", "RULES", "BY_NAME", "STATE_RULES", "Refusal", "rules_of"]


@dataclass(frozen=True)
class Rule:
    """A rule: `name` is `<action>.<what>` (a step's precondition, or `<action>.effect`: the
    next configuration is the action's effect) or `state.<what>` (every configuration);
    `text` says what it asks; `witness`, when not "", why the planted-rule test cannot see
    it alone on the `side` ("python", "alloy" or "both") it names."""

    name: str
    text: str
    witness: str = ""
    side: str = ""

    @property
    def judged(self) -> str:
        """What the rule is about: "state", or the name of an action."""
        return self.name.split(".", 1)[0]


@dataclass(frozen=True)
class Refusal:
    """A rule that does not hold, in words."""

    rule: str
    text: str

    def __str__(self) -> str:
        return self.text


_ABSENT = ("every functionality of an absent component counts as degraded in Alloy (assert AbsentDegraded), "
           "so {} refuses the same step there too")

RULES: tuple[Rule, ...] = tuple(Rule(*row) for row in (
    ("state.valid", "every assumption of every present functionality's current mode holds (the safety property)"),
    ("state.single", "a `single` topic has at most one attached publisher"),
    ("state.service", "a service has at most one attached server"),
    ("state.typed", "every attached port carries its connector's message type"),
    ("state.owned", "every attached port is a port of a present component"),
    ("remove.present", "the component is present"),
    ("remove.isolated", "no port of the component is attached"),
    ("remove.effect", "the component leaves, nothing else changes"),
    ("create.absent", "the component is absent"),
    ("create.degraded", "every functionality of the component is created degraded",
     "the Python engine records no mode for an absent component and Alloy reads it as degraded, so a "
     "resolved architecture never breaks it; the meta-model's proof needs it (tests/alloy/test_mutations.py)",
     "both"),
    ("create.effect", "the component arrives, nothing else changes"),
    ("detach.attached", "the port is attached to the connector"),
    ("detach.present", "the port is a port of a present component"),
    ("detach.input", "an input's component stays safe without the attachment"),
    ("detach.output", "when no other output satisfies the connector, its readers stay safe without it"),
    ("detach.effect", "the attachment goes, nothing else changes"),
    ("attach.present", "the port is a port of a present component"),
    ("attach.detached", "the port is not yet attached to the connector"),
    ("attach.output", "an output's current guarantee satisfies the connector's"),
    ("attach.input", "the connector's guarantee satisfies an input's assumption"),
    ("attach.single", "an output is not attached to a `single` topic that has a publisher"),
    ("attach.service", "an output is not attached to a service that has a server"),
    ("attach.effect", "the attachment arrives, nothing else changes"),
    ("degrade.present", "the functionality's component is present", _ABSENT.format("degrade.normal"), "alloy"),
    ("degrade.normal", "the functionality is in its normal mode"),
    ("degrade.safe", "the readers of the connectors it leaves unsatisfied stay safe without them"),
    ("degrade.effect", "the functionality is degraded, nothing else changes"),
    ("upgrade.present", "the functionality's component is present",
     _ABSENT.format("upgrade.effect (its functionality stays degraded)"), "alloy"),
    ("upgrade.degraded", "the functionality is degraded"),
    ("upgrade.assumptions", "every assumption of its normal mode holds"),
    ("upgrade.connectors", "no satisfied connector is left unsatisfied (rule iii on modes)"),
    ("upgrade.effect", "the functionality is normal, nothing else changes"),
))

BY_NAME: dict[str, Rule] = {r.name: r for r in RULES}
STATE_RULES: tuple[Rule, ...] = tuple(r for r in RULES if r.judged == "state")


def rules_of(judged: str) -> tuple[Rule, ...]:
    """The rules about `judged` ("state" or an action's name), in the table's order."""
    return tuple(r for r in RULES if r.judged == judged)
