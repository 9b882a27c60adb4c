"""The typed IR of an architecture: frozen dataclasses, each with a Span.

Spans are excluded from equality and hashing, so two IRs compare equal when they say
the same thing, wherever it was written (this is what the `fmt` round-trip relies on).
Rates are exact fractions in hertz: `@ 100 ms` and `@ 10 Hz` are the same rate.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property, lru_cache
from typing import Literal, Optional, Union

from .span import NO_SPAN, Span

PortKind = Literal["input", "output"]
ModeKind = Literal["normal", "degraded"]
ConnectorKind = Literal["topic", "service"]


def _span() -> Span:
    return field(default=NO_SPAN, compare=False, hash=False, repr=False)  # type: ignore[return-value]


@dataclass(frozen=True)
class Rate:
    """A rate as written: value and unit (`10 Hz`, `2 kHz`, `100 ms`); `hz` is exact."""

    value: Fraction
    unit: str
    span: Span = _span()

    @cached_property
    def hz(self) -> Fraction:
        return rate_in_hz(self.value, self.unit)


FREQUENCY_UNITS = {"Hz": Fraction(1), "kHz": Fraction(1000), "MHz": Fraction(1_000_000)}
PERIOD_UNITS = {"s": Fraction(1), "ms": Fraction(1, 1000), "us": Fraction(1, 1_000_000)}
UNITS = {**FREQUENCY_UNITS, **PERIOD_UNITS}


@lru_cache(maxsize=4096)
def rate_in_hz(value: Fraction, unit: str) -> Fraction:
    """`value` in `unit` as hertz (kept: a system writes the same few rates thousands of times)."""
    if unit in FREQUENCY_UNITS:
        return value * FREQUENCY_UNITS[unit]
    if value == 0:
        return Fraction(0)
    return 1 / (value * PERIOD_UNITS[unit])


@dataclass(frozen=True)
class Predicate:
    """*nothing* (message is None) or a message type with an optional rate."""

    message: Optional[str]
    rate: Optional[Rate] = None
    span: Span = _span()

    @property
    def is_nothing(self) -> bool:
        return self.message is None

    @property
    def hz(self) -> Optional[Fraction]:
        return None if self.rate is None else self.rate.hz

    def __str__(self) -> str:
        if self.message is None:
            return "nothing"
        if self.rate is None:
            return self.message
        return f"{self.message} @ {format_number(self.rate.value)} {self.rate.unit}"


def format_number(x: Fraction) -> str:
    if x.denominator == 1:
        return str(x.numerator)
    text = f"{float(x):.12g}"
    return text


NOTHING = Predicate(None)


@dataclass(frozen=True)
class MessageType:
    name: str
    ros_type: str
    span: Span = _span()


@dataclass(frozen=True)
class EnvGuarantee:
    name: str
    guarantee: Predicate
    span: Span = _span()


@dataclass(frozen=True)
class Port:
    """An input (subscriber) with its assumption, or an output (publisher) with its type."""

    name: str
    kind: PortKind
    message: str
    assumption: Optional[Predicate] = None  # inputs only
    span: Span = _span()


@dataclass(frozen=True)
class Guarantee:
    port: str
    predicate: Predicate
    span: Span = _span()


@dataclass(frozen=True)
class Mode:
    kind: ModeKind
    assumptions: tuple[Predicate, ...] = ()
    guarantees: tuple[Guarantee, ...] = ()
    span: Span = _span()

    def guarantee(self, port: str) -> Predicate:
        for g in self.guarantees:
            if g.port == port:
                return g.predicate
        return NOTHING


@dataclass(frozen=True)
class Functionality:
    name: str
    ports: tuple[str, ...]
    normal: Optional[Mode]
    degraded: Optional[Mode]
    criticality: int = 1
    span: Span = _span()


@dataclass(frozen=True)
class FtmExpr:
    """A fault-tolerance mechanism, possibly nested: `SEC(PBR(TR))`."""

    name: str
    inner: Optional["FtmExpr"] = None
    span: Span = _span()

    def __str__(self) -> str:
        return self.name if self.inner is None else f"{self.name}({self.inner})"


@dataclass(frozen=True)
class ResourceSetting:
    name: str
    value: str
    span: Span = _span()


# The six actions by name, in the order the semantic model registers them
# (checker.semantic_model.actions.KINDS, held to this by a test): what a `takes` line may name.
ACTIONS = ("remove", "create", "detach", "attach", "degrade", "upgrade")


@dataclass(frozen=True)
class Take:
    """`takes create 2.5 s`: how long one action on this component takes, as written."""

    action: str
    value: Fraction
    unit: str                          # "s" or "ms"
    span: Span = _span()

    @property
    def seconds(self) -> Fraction:
        return self.value * PERIOD_UNITS[self.unit]

    def __str__(self) -> str:
        return f"{self.action} {format_number(self.value)} {self.unit}"


@dataclass(frozen=True)
class FtmDecl:
    expr: FtmExpr
    hosts: tuple[str, ...] = ()
    span: Span = _span()


ParamValue = Union[bool, int, float, str]


@dataclass(frozen=True)
class Effect:
    """What one mode of a functionality does to a node not built with reconf: `deactivate` it (a
    lifecycle node), `hold` back what the mode guarantees nothing on (the adapter does, whatever
    else the mode does), or `set` one of its parameters (`param`) to `value`."""

    kind: Literal["deactivate", "hold", "set"]
    param: str = ""
    value: ParamValue = ""
    span: Span = _span()


@dataclass(frozen=True)
class NodeTopic:
    """A port's ROS name inside the node's executable (`out = /chatter`), which reconf remaps."""

    port: str
    ros_name: str
    span: Span = _span()


@dataclass(frozen=True)
class NodeMode:
    """What a mode of one functionality means for the node (`talk degraded: deactivate`)."""

    functionality: str
    mode: ModeKind
    effects: tuple[Effect, ...] = ()
    span: Span = _span()


@dataclass(frozen=True)
class RosNode:
    """A component that is not a reconf node: the ROS node `name` of its `run` command, driven by
    an adapter that implements the control interface on its behalf (docs/adapter.md)."""

    name: str
    lifecycle: bool = False
    topics: tuple[NodeTopic, ...] = ()
    modes: tuple[NodeMode, ...] = ()
    span: Span = _span()

    def ros_name(self, port: str) -> Optional[str]:
        return next((t.ros_name for t in self.topics if t.port == port), None)

    def effects(self, functionality: str, mode: str) -> tuple[Effect, ...]:
        """What `mode` of `functionality` does to the node; a degraded mode without a line holds."""
        for m in self.modes:
            if m.functionality == functionality and m.mode == mode:
                return m.effects
        return (Effect("hold"),) if mode == "degraded" else ()


@dataclass(frozen=True)
class Component:
    name: str
    ports: tuple[Port, ...] = ()
    functionalities: tuple[Functionality, ...] = ()
    run: Optional[str] = None
    host: Optional[str] = None
    replaces: Optional[str] = None
    faults: tuple[str, ...] = ()
    application: tuple[str, ...] = ()
    resources: tuple[ResourceSetting, ...] = ()
    ftm: Optional[FtmDecl] = None
    node: Optional[RosNode] = None     # not a reconf node: how its adapter drives it
    takes: tuple[Take, ...] = ()       # actions that take longer or shorter than the measured defaults
    span: Span = _span()

    def port(self, name: str) -> Optional[Port]:
        return self._ports_by_name.get(name)

    @cached_property
    def _ports_by_name(self) -> dict[str, Port]:
        by_name: dict[str, Port] = {}
        for p in self.ports:
            by_name.setdefault(p.name, p)  # the first declaration wins, as duplicates are errors
        return by_name

    @property
    def inputs(self) -> tuple[Port, ...]:
        return tuple(p for p in self.ports if p.kind == "input")

    @property
    def outputs(self) -> tuple[Port, ...]:
        return tuple(p for p in self.ports if p.kind == "output")


@dataclass(frozen=True)
class PortRef:
    component: str
    port: str
    span: Span = _span()

    def __str__(self) -> str:
        return f"{self.component}.{self.port}"


@dataclass(frozen=True)
class Connector:
    """A topic, or a service (a connector with exactly one server)."""

    name: str
    kind: ConnectorKind
    guarantee: Predicate
    single: bool = False
    publishers: tuple[PortRef, ...] = ()
    subscribers: tuple[PortRef, ...] = ()
    span: Span = _span()

    @property
    def roles(self) -> tuple[PortRef, ...]:
        return self.publishers + self.subscribers

    @property
    def single_publisher(self) -> bool:
        return self.single or self.kind == "service"


@dataclass(frozen=True)
class Host:
    name: str
    resources: tuple[ResourceSetting, ...] = ()
    span: Span = _span()


@dataclass(frozen=True)
class Include:
    path: str
    span: Span = _span()


Item = (MessageType | EnvGuarantee | Component | Connector | Host | Include)


@dataclass(frozen=True)
class Document:
    """One parsed file, as written: the unit the formatter works on."""

    file: str
    system: Optional[str]
    items: tuple[Item, ...]
    system_span: Span = _span()
    comments: tuple[tuple[int, int, str], ...] = field(default=(), compare=False, hash=False, repr=False)


@dataclass(frozen=True)
class System:
    """A whole architecture: every file's items merged and resolved.

    `components` are deployed; `versions` are declared replacements (`replaces`), not deployed.
    """

    name: str
    messages: tuple[MessageType, ...]
    environment: tuple[EnvGuarantee, ...]
    components: tuple[Component, ...]
    versions: tuple[Component, ...]
    connectors: tuple[Connector, ...]
    hosts: tuple[Host, ...] = ()
    files: tuple[str, ...] = ()
    span: Span = _span()

    def component(self, name: str) -> Optional[Component]:
        for c in self.components + self.versions:
            if c.name == name:
                return c
        return None

    def connector(self, name: str) -> Optional[Connector]:
        for c in self.connectors:
            if c.name == name:
                return c
        return None

    def message(self, name: str) -> Optional[MessageType]:
        for m in self.messages:
            if m.name == name:
                return m
        return None


def satisfies(p: Predicate, q: Predicate) -> bool:
    """p satisfies q iff both are data of the same type and (q has no rate, or p has a rate ≥ q's).

    *nothing* satisfies nothing, and nothing is satisfied only vacuously (never asked for)."""
    if p.message is None or q.message is None or p.message != q.message:
        return False
    q_hz = q.hz
    if q_hz is None:
        return True
    p_hz = p.hz
    return p_hz is not None and p_hz >= q_hz
