"""A plan document's parts as types, and the words for a step.

A plan document is JSON (format 1 or 2, `codegen/ros2.py`); the executor reads it into these
types once, at its edge, and passes typed values from then on."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Optional, TypedDict

# The symbol of each action, as `reconf plan` prints it (held to the checker's action registry
# by tests/test_tables.py).
SYMBOLS = {"create": "+", "remove": "-", "attach": "\u2192", "detach": "\u00d7", "degrade": "\u2193",
           "upgrade": "\u2191"}
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class PredicateDoc(TypedDict):
    """`T @ r` as data: `message` None for `nothing`, `hz` an exact fraction as text or None."""
    message: Optional[str]
    hz: Optional[str]
    text: str


class PortDoc(TypedDict):
    name: str
    kind: str                          # "input" or "output"
    message: str
    assumption: Optional[PredicateDoc]


class GuaranteeDoc(TypedDict):
    port: str
    predicate: PredicateDoc


class ModeDoc(TypedDict):
    assumptions: list[PredicateDoc]
    guarantees: list[GuaranteeDoc]


class FunctionalityDoc(TypedDict):
    name: str
    ports: list[str]
    criticality: int
    normal: ModeDoc
    degraded: ModeDoc


class ComponentDoc(TypedDict, total=False):
    name: str
    deployed: bool
    replaces: Optional[str]
    run: Optional[str]
    host: Optional[str]
    ports: list[PortDoc]
    functionalities: list[FunctionalityDoc]
    node: dict[str, Any]               # not a reconf node: how its adapter drives it (docs/adapter.md)


class ConnectorDoc(TypedDict, total=False):
    name: str
    kind: str                          # "topic" or "service"
    guarantee: PredicateDoc
    single: bool


class EnvironmentDoc(TypedDict):
    name: str
    guarantee: PredicateDoc


class ModelDoc(TypedDict, total=False):
    """The architecture as plain data (`codegen.ros2.model_data`)."""
    name: str
    components: list[ComponentDoc]
    connectors: list[ConnectorDoc]
    environment: list[EnvironmentDoc]


@dataclass(frozen=True)
class Step:
    """One action of a plan: `component` always; `port` and `connector` for attach and detach,
    `functionality` for degrade and upgrade."""
    action: str
    component: str
    port: str = ""
    connector: str = ""
    functionality: str = ""

    @staticmethod
    def from_doc(d: dict[str, Any]) -> "Step":
        return Step(str(d["action"]), str(d["component"]), str(d.get("port", "")), str(d.get("connector", "")),
                    str(d.get("functionality", "")))

    @property
    def role(self) -> tuple[str, str, str]:
        """The attachment an attach or a detach is about: (connector, component, port)."""
        return (self.connector, self.component, self.port)

    def describe(self) -> str:
        if self.action == "create":
            return f"create {self.component} (all functionalities degraded)"
        if self.action == "remove":
            return f"remove {self.component}"
        if self.action == "attach":
            return f"attach {self.component}.{self.port} to {self.connector}"
        if self.action == "detach":
            return f"detach {self.component}.{self.port} from {self.connector}"
        return f"{self.action} {self.component}.{self.functionality}"

    def label(self, i: int) -> str:
        """The step as a numbered line of a plan: `  3. → attach talker_v2.out to /chatter`."""
        return f"{i:>3}. {SYMBOLS.get(self.action, '?')} {self.describe()}"


def plan_steps(doc: dict[str, Any]) -> list[Step]:
    """The steps of a plan document, typed."""
    return [Step.from_doc(s) for s in doc["plan"]["steps"]]


def batches(doc: dict[str, Any]) -> list[tuple[int, int]]:
    """The plan's batches: (first, last) step, from 1, of each run of steps carried out together
    (docs/executor.md#batches)."""
    return [(int(a), int(b)) for a, b in doc["plan"].get("batches") or []]


def batch_end(ctx: Any, i: int, last: int) -> int:
    """The last step to perform together with step `i` (`i` itself when it is in no batch): the
    end of its batch, or `last`, where the run stops first. A run that starts inside a batch
    performs the rest of it together: any part of a batch is one (docs/soundness.md#batches)."""
    for a, b in ctx.batches:
        if a <= i <= b:
            return min(b, last)
    return i


def restoring(doc: dict[str, Any]) -> int:
    """How many first steps of a recovery's plan restore validity (docs/executor.md#failure-and-recovery)."""
    return int((doc["plan"].get("recovery") or {}).get("restore", 0))


def orphans(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """The nodes a recovery's plan ends before its first step (docs/executor.md#recovering-from-the-live-system)."""
    return list((doc["plan"].get("recovery") or {}).get("orphans") or [])


def join_list(items: Iterable[str]) -> str:
    return ",".join(sorted(items))


def plural(n: int, word: str, many: str = "") -> str:
    """A count and its noun in agreement: `1 step`, `3 steps`."""
    return f"{n} {word if n == 1 else (many or word + 's')}"
