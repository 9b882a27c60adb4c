"""What an Alloy module of a concrete architecture says, before it is text.

codegen.alloy builds these descriptions (which atoms, which constants, which states, which
steps) and the templates of codegen/templates/alloy/ render them, deciding nothing.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

__all__ = ["EVALUATION_SIGS", "plan_evaluation_sigs", "Architecture", "EvaluationSig", "Family", "Fun", "InstanceData", "InstanceModule",
           "Meaning", "PlanModule", "PlannerModule", "Serving", "StateTerms", "Step"]

# What an atom stands for: ("component", c), ("port", c, p), ("functionality", c, f),
# ("connector", k), ("message", m), ("rate", hz), ("data", message, hz or ""), ("state", i),
# ("guarantee", c, f, p).
Meaning = tuple[str, ...]


@dataclass(frozen=True)
class Family:
    """An abstract sig `parent` (extending `extends`, if any) and one `one sig` per atom.
    A `closed` family without atoms has a fact saying the sig has none (an abstract sig
    without children could still hold atoms)."""

    parent: str
    atoms: tuple[str, ...]
    extends: str = ""
    closed: bool = True


@dataclass(frozen=True)
class Fun:
    """A `fun` constant: its name, its type and its body (an Alloy expression)."""

    name: str
    type: str
    body: str


@dataclass(frozen=True)
class Architecture:
    """A system's atoms and its fixed relations, as every module of it declares them;
    `names` says what each atom stands for, and `guar_atoms` whether guarantees are atoms
    of their own (binary relations) rather than a ternary relation."""

    families: tuple[Family, ...]
    funs: tuple[Fun, ...]
    guar_atoms: bool
    names: dict[str, Meaning]

    def atom(self, meaning: Meaning) -> str:
        """The atom that stands for `meaning`."""
        return self.atoms()[meaning]

    def atoms(self) -> dict[Meaning, str]:
        """Every atom by what it stands for."""
        return {meaning: name for name, meaning in self.names.items()}


@dataclass(frozen=True)
class InstanceModule:
    """One configuration of an architecture: its relations as constants."""

    module_name: str
    system_name: str
    architecture: Architecture
    configuration: tuple[Fun, ...]
    valid: bool = True          # the expectation its `check Valid` states (the caller's verdict)


@dataclass(frozen=True)
class EvaluationSig:
    """A sig of the evaluation module (codegen/templates/alloy/evaluate.als.j2): its name,
    the sig it extends (or, `subset`, is a subset of), and its fields (name, range; every
    field is `set`, so the module constrains nothing an instance gives)."""

    name: str
    parent: str = ""
    abstract: bool = False
    one: bool = False
    subset: bool = False
    fields: tuple[tuple[str, str], ...] = ()


# The sigs of an architecture, in order, as the evaluation modules declare them: the
# relations of an instance module's `fun` constants, with guarantees as atoms (binary
# relations only). `Connector` and `Component` are not here: each module adds its own fields.
_ARCHITECTURE_SIGS = (
    EvaluationSig("MType"),
    EvaluationSig("Rate", fields=(("rate_next", "Rate"),)),
    EvaluationSig("Data", abstract=True),
    EvaluationSig("Nothing", "Data", one=True),
    EvaluationSig("Msg", "Data", fields=(("mtype", "MType"), ("rate", "Rate"))),
    EvaluationSig("Port", abstract=True, fields=(("ptype", "MType"),)),
    EvaluationSig("Input", "Port", fields=(("iasm", "Data"),)),
    EvaluationSig("Output", "Port"),
    EvaluationSig("Functionality", fields=(("assoc_in", "Input"), ("assoc_out", "Output"), ("nasms", "Data"))),
    EvaluationSig("Guar", fields=(("gfunc", "Functionality"), ("gout", "Output"), ("gn", "Data"), ("gd", "Data"))),
    EvaluationSig("envg", "Data", subset=True),
)
# the `single` topics and the services
_CONNECTOR_KINDS = (EvaluationSig("single", "Connector", subset=True), EvaluationSig("service", "Connector", subset=True))
_COMPONENT_FIELDS = (("inputs", "Input"), ("outputs", "Output"), ("funcs", "Functionality"))

# The evaluation module's sigs (codegen/templates/alloy/evaluate.als.j2): an architecture in
# one configuration. The one table from which the module's declarations and every instance
# of it (codegen.alloy_xml) are written.
EVALUATION_SIGS = _ARCHITECTURE_SIGS + (
    EvaluationSig("Component", fields=_COMPONENT_FIELDS),
    EvaluationSig("Connector", fields=(("cguar", "Data"), ("roles", "Port"))),
    *_CONNECTOR_KINDS,
    EvaluationSig("comps", "Component", subset=True),
    EvaluationSig("degraded", "Functionality", subset=True),
)


def plan_evaluation_sigs(action_kinds: tuple[str, ...]) -> tuple[EvaluationSig, ...]:
    """The plan evaluation module's sigs (plan_evaluate.als.j2): an architecture in the
    successive configurations of a plan (System atoms, their attachments through Role
    atoms), its steps (each with the states around it, its arguments by kind, and the
    subset `<action>_steps` of the action it is), and what the plan must keep serving."""
    return _ARCHITECTURE_SIGS + (
        EvaluationSig("Component", fields=_COMPONENT_FIELDS + (("protocols", "Component"),)),
        EvaluationSig("Connector", fields=(("cguar", "Data"),)),
        *_CONNECTOR_KINDS,
        EvaluationSig("Role", fields=(("role_conn", "Connector"), ("role_port", "Port"))),
        EvaluationSig("System", fields=(("comps", "Component"), ("degraded", "Functionality"), ("sroles", "Role"))),
        EvaluationSig("Step", fields=(("pre", "System"), ("post", "System"), ("a_component", "Component"),
                                      ("a_connector", "Connector"), ("a_port", "Port"),
                                      ("a_functionality", "Functionality"))),
        *(EvaluationSig(f"{kind}_steps", "Step", subset=True) for kind in action_kinds),
        EvaluationSig("proxies", "Functionality", subset=True),
        EvaluationSig("client_conns", "Connector", subset=True),
        EvaluationSig("proxy_comps", "Component", subset=True),
        EvaluationSig("handing", "Component", subset=True),
        EvaluationSig("handed_conns", "Connector", subset=True),
        EvaluationSig("stable_conns", "Connector", subset=True),
    )


@dataclass(frozen=True)
class InstanceData:
    """One configuration of (a slice of) an architecture as an instance of the evaluation
    module: each sig's own atoms and each field's tuples, by name (EVALUATION_SIGS), and
    what each atom stands for."""

    system_name: str
    atoms: dict[str, tuple[str, ...]]
    fields: dict[str, tuple[tuple[str, ...], ...]]
    names: dict[str, Meaning]


@dataclass(frozen=True)
class Step:
    """A step of a plan that is one action: the action predicate, the two states and the
    arguments' atoms."""

    action: str
    before: str
    after: str
    args: tuple[str, ...]

    @property
    def sig(self) -> str:
        """The action's atom of sig Action."""
        return self.action.capitalize()


@dataclass(frozen=True)
class Serving:
    """What a plan must keep serving (`fun` constants): the proxies, their clients'
    connectors, and with `protocols` (proxy -> protocol), the proxies' components and
    the servers losing their FTM (`handing`) with their connectors (`handed`)."""

    proxies: str
    connectors: str
    handing: str
    handed: str
    protocols: str = ""
    proxy_comps: str = ""


@dataclass(frozen=True)
class PlanModule:
    """The successive configurations of a plan: the states, their relations, and per step
    the action it is (None where the difference is not one action)."""

    module_name: str
    system_name: str
    architecture: Architecture
    states: tuple[str, ...]
    configurations: tuple[Fun, ...]
    roles: tuple[Family, ...]            # the Role atoms, with binary roles
    binary: bool
    actions: tuple[str, ...]             # the sigs of Action, one per action kind
    steps: tuple[Optional[Step], ...]
    ok_steps: str                        # System -> Action: each one-action step's candidate
    serving: Optional[Serving] = None
    stable: Optional[str] = None         # the connectors every configuration keeps satisfied


@dataclass(frozen=True)
class StateTerms:
    """A configuration as Alloy terms: its components, its attachments, its degraded
    functionalities."""

    comps: str
    roles: str
    degraded: str


@dataclass(frozen=True)
class PlannerModule:
    """A reconfiguration searched as an Alloy trace (checker.planning.alloy_search)."""

    module_name: str
    system_name: str
    architecture: Architecture
    actions: str            # the actions over the current and the next state
    crit: str               # Functionality -> Int
    bound: Optional[int]    # on disruption
    start_weight: int
    bitwidth: int
    states: int
    min_states: int
    start: StateTerms
    goal: StateTerms
