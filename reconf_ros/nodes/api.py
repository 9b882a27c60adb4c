"""The Component API of paper 001 §5.2, its model half: ports, functionalities, modes.

Nothing here needs ROS: a component can be described, printed as `.arch` text and checked by
`reconf` on a machine without rclpy. `Component.start()` (in `component.py`) brings it up as a
lifecycle node. See docs/runtime.md.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable, Optional, Sequence, Union

__all__ = ["Component", "Functionality", "Input", "Output", "Mode", "Predicate", "ros_type_name", "parse_predicate",
           "DeclarationError"]

MsgType = Union[str, type]
RateLike = Union[int, float, Fraction, str, "Rate", None]


class DeclarationError(ValueError):
    """A component described inconsistently (unknown port, a mode for a port it does not use…)."""


def ros_type_name(msg_type: MsgType) -> str:
    """`std_msgs/msg/String` for the class `std_msgs.msg.String` or for the string itself.
    DeclarationError for a string not of the form `pkg/msg/Type` (or `pkg/srv/Type`), or a class
    that is not a ROS 2 message or service class."""
    if isinstance(msg_type, str):
        if not re.fullmatch(r"[A-Za-z_][\w]*/(msg|srv)/[A-Za-z_]\w*", msg_type):
            raise DeclarationError(f"{msg_type!r} is not a ROS 2 type name like std_msgs/msg/String")
        return msg_type
    module = getattr(msg_type, "__module__", "")
    package = module.split(".")[0]
    if not package or ".msg" not in module and ".srv" not in module:
        raise DeclarationError(f"{msg_type!r} is not a ROS 2 message class")
    kind = "srv" if ".srv" in module else "msg"
    return f"{package}/{kind}/{msg_type.__name__}"


_UNITS = {"hz": Fraction(1), "khz": Fraction(1000), "s": None, "ms": None, "us": None}
_PERIOD = {"s": Fraction(1), "ms": Fraction(1, 1000), "us": Fraction(1, 1_000_000)}


def _fraction(x: Union[int, float, Fraction, str]) -> Fraction:
    return Fraction(x) if not isinstance(x, float) else Fraction(str(x))


@dataclass(frozen=True)
class Rate:
    """A rate as written (`10 Hz`, `100 ms`): `value` in `unit` (Hz, kHz, s, ms or us); `hz` is
    exact. Made by `to_rate`, which refuses a rate that is not positive."""

    value: Fraction
    unit: str = "Hz"

    @property
    def hz(self) -> Fraction:
        """The rate in Hz, exactly: a frequency scaled (2 kHz is 2000), a period inverted (100 ms
        is 10)."""
        if self.unit in ("Hz", "kHz"):
            return self.value * (1000 if self.unit == "kHz" else 1)
        return 1 / (self.value * _PERIOD[self.unit])

    def __str__(self) -> str:
        v = self.value
        text = str(v.numerator) if v.denominator == 1 else f"{float(v):.12g}"
        return f"{text} {self.unit}"


def to_rate(rate: RateLike) -> Optional[Rate]:
    """10 → 10 Hz; "10 Hz", "100 ms", "2 kHz", "1 s" as written; None stays None. A float is taken
    as written (0.1 is 1/10). DeclarationError for text that is not a rate, or a value that is
    not positive."""
    if rate is None:
        return None
    if isinstance(rate, Rate):
        return rate
    if isinstance(rate, str):
        m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]+)?)\s*(Hz|kHz|s|ms|us)\s*", rate)
        if not m:
            raise DeclarationError(f"{rate!r} is not a rate like '10 Hz' or '100 ms'")
        value, unit = _fraction(m.group(1)), m.group(2)
    else:
        value, unit = _fraction(rate), "Hz"
    if value <= 0:
        raise DeclarationError(f"a rate must be positive, not {rate!r}")
    return Rate(value, unit)


@dataclass(frozen=True)
class Predicate:
    """A message type (by its alias in the architecture) with an optional rate."""

    alias: str
    rate: Optional[Rate] = None

    @property
    def hz(self) -> Optional[Fraction]:
        """The rate asked or promised, in Hz; None when the predicate has no rate."""
        return None if self.rate is None else self.rate.hz

    def satisfies(self, other: "Predicate") -> bool:
        """Same type, and other asks no rate or self promises at least other's
        (docs/design.md#the-semantic-model)."""
        if self.alias != other.alias:
            return False
        if other.hz is None:
            return True
        return self.hz is not None and self.hz >= other.hz

    def __str__(self) -> str:
        return self.alias if self.rate is None else f"{self.alias} @ {self.rate}"


def parse_predicate(text: str) -> Predicate:
    """`"Image @ 15 Hz"`, `"Obstacles @ 1 s"`, `"String"`: a type alias as the architecture names it,
    and an optional rate. DeclarationError for anything else."""
    alias, _, rate = text.partition("@")
    alias = alias.strip()
    if not re.fullmatch(r"[A-Za-z_]\w*", alias):
        raise DeclarationError(f"{text!r} is not a predicate like 'String @ 10 Hz'")
    return Predicate(alias, to_rate(rate) if rate.strip() else None)


@dataclass(eq=False)
class Port:
    """A port of a component: its name, its ROS type (`pkg/msg/Type`) and the alias the
    architecture calls that type by. Made by `Component.create_input` or `create_output`, never
    directly. Ports compare by identity."""

    component: "Component"
    name: str
    msg_type: str            # pkg/msg/Type
    alias: str               # its name in the architecture
    # A port on a service: an output answers requests, an input sends them. Requests travel on
    # `<connector>/request`, replies on the connector itself (docs/runtime.md#services).
    service: bool = field(default=False, kw_only=True)
    # Durable (transient-local) data is replayed to a subscriber that matches late; requests
    # must not be: a protocol attached during a transition would run old requests again.
    durable: bool = field(default=True, kw_only=True)
    # An input whose messages answer what the node asked for (a service's replies, a pipeline's
    # results): its rate is owed only while something is asked (`Input.expect`), see
    # docs/runtime.md#services.
    on_demand: bool = field(default=False, kw_only=True)

    @property
    def message_class(self) -> Any:
        """The rclpy message class (imported on first use); ImportError or AttributeError when
        the message package is not installed or has no such type."""
        import importlib
        package, kind, name = self.msg_type.split("/")
        return getattr(importlib.import_module(f"{package}.{kind}"), name)


@dataclass(eq=False)
class Input(Port):
    """A subscriber; its assumption is what it needs of its topic (paper 001: `create_input`)."""

    assumption: Predicate = field(default=Predicate(""))
    listeners: list[Callable[[Any], None]] = field(default_factory=list)
    kind = "input"

    def on_message(self, callback: Callable[[Any], None]) -> "Input":
        """Call `callback(msg)` on every message, whatever the mode (the monitor measures it too)."""
        self.listeners.append(callback)
        return self

    def request(self, msg: Any) -> bool:
        """On a service port: send a request to the server(s) and expect its answer; False when
        nothing was sent (the component is not running, its node not active, or the port attached
        to nothing). True when it was published on `<connector>/request` of every connector the
        port is attached to; on an on-demand port one answer is then owed (`expect`). `msg` is a
        message of the port's type or the value of its `data` field. DeclarationError on a port
        not on a service."""
        if not self.service:
            raise DeclarationError(f"{self.component.name}.{self.name} is not on a service")
        node = self.component.node
        if node is None or not node.send_request(self.name, msg):
            return False
        self.expect()
        return True

    def expect(self) -> None:
        """Note that one message is now owed on this on-demand input (the next arrival pays it).
        The monitor judges an on-demand input's rate only while something is owed. Does nothing
        before the component runs, or on an input that is not on demand."""
        node = self.component.node
        if node is not None and self.on_demand:
            node.expect(self.name)

    def give_up(self) -> None:
        """Note that the oldest message owed on this on-demand input will not come (its request
        was given up): the monitor no longer counts the wait for it."""
        node = self.component.node
        if node is not None and self.on_demand:
            node.give_up(self.name)

    def read(self) -> Any:
        """The last message received on any of the port's connectors (None before the first, or
        before the component runs), whatever the mode or lifecycle state."""
        node = self.component.node
        return None if node is None else node.last_message(self.name)


@dataclass(eq=False)
class Output(Port):
    """A publisher (paper 001: `create_output`)."""

    handlers: list[Callable[[Any], None]] = field(default_factory=list)
    kind = "output"

    def on_request(self, callback: Callable[[Any], None]) -> "Output":
        """On a service port: call `callback(request)` for every request, whatever the mode;
        replies are written with `write()` (so a mode that guarantees nothing answers nothing).
        Requests that arrive while the node is not active are kept and handed over, in order, on
        activation. An exception in the callback is counted in the node's status, not raised.
        Returns the port; DeclarationError on a port not on a service."""
        if not self.service:
            raise DeclarationError(f"{self.component.name}.{self.name} is not on a service")
        self.handlers.append(callback)
        return self

    def new(self, **fields: Any) -> Any:
        """A message of the port's type with `fields` set (`out.new(data="hello")`); the message
        package must be installed (see `message_class`)."""
        return self.message_class(**fields)

    def write(self, msg: Any) -> bool:
        """Publish on every connector the port is attached to; False when nothing was published
        (not attached, not running, or the current mode guarantees nothing on this port). `msg`
        is a message of the port's type, or the value of its `data` field. Call it from the
        component's callbacks (the node's executor thread)."""
        node = self.component.node
        return False if node is None else node.write(self.name, msg)


Callback = Callable[..., Any]


@dataclass
class Mode:
    """A mode's behaviour and model: the callback, its rate (None: once per input message),
    the guarantee on each output, and the assumptions."""

    kind: str
    callback: Optional[Callback] = None
    rate: Optional[Rate] = None
    guarantees: dict[str, Optional[Rate]] = field(default_factory=dict)   # port -> rate (None: no rate)
    assumes: list[Predicate] = field(default_factory=list)


class Functionality:
    """A functionality with a normal and a degraded mode (paper 001: `create_functionality`)."""

    def __init__(self, component: "Component", name: str, inputs: Sequence[Input], outputs: Sequence[Output],
                 criticality: int) -> None:
        self.component, self.name, self.criticality = component, name, criticality
        self.inputs, self.outputs = list(inputs), list(outputs)
        self.normal = Mode("normal", assumes=[i.assumption for i in self.inputs if i.assumption.alias])
        self.degraded = Mode("degraded")

    @property
    def ports(self) -> list[str]:
        """The names of the ports it is associated with, inputs first, in declaration order."""
        return [p.name for p in self.inputs] + [p.name for p in self.outputs]

    def _mode(self, mode: Mode, callback: Optional[Callback], rate: RateLike,
              outputs: Union[Sequence[Output], dict[Output, RateLike], None]) -> None:
        mode.callback, mode.rate = callback, to_rate(rate)
        if outputs is None:
            outputs = []
        items = outputs.items() if isinstance(outputs, dict) else [(o, rate) for o in outputs]
        mode.guarantees = {}
        for out, r in items:
            if out not in self.outputs:
                raise DeclarationError(f"{self.component.name}.{self.name}: {getattr(out, 'name', out)} is not one of "
                                 "its outputs")
            mode.guarantees[out.name] = to_rate(r)

    def set_normal_mode(self, callback: Optional[Callback] = None, rate: RateLike = None,
                        outputs: Union[Sequence[Output], dict[Output, RateLike], None] = None,
                        assumes: Optional[Sequence[Union[str, Predicate]]] = None) -> "Functionality":
        """Run `callback` at `rate` (or on every message of an input when no rate), guarantee
        each output in `outputs` at `rate` (a dict gives each its own), and assume `assumes`
        (by default what the functionality's inputs assume).

        Outputs left out guarantee nothing in this mode. Declare before `Component.start()`: the
        model the node publishes (`reconf.model`) is made when it starts, and a running node
        reads a mode's behaviour when it switches to it. Returns the functionality;
        DeclarationError for an output not associated with it, a rate that is not a rate, or an
        assumption that is not a predicate."""
        self._mode(self.normal, callback, rate, outputs)
        if assumes is not None:
            self.normal.assumes = [a if isinstance(a, Predicate) else parse_predicate(a) for a in assumes]
        return self

    def set_degraded_mode(self, callback: Optional[Callback] = None, rate: RateLike = None,
                          outputs: Union[Sequence[Output], dict[Output, RateLike], None] = None) -> "Functionality":
        """The degraded mode assumes nothing; `outputs` are the ports it still serves (e.g. zero
        velocities at 20 Hz); every other output is silent. Whatever a degraded guarantee
        satisfies, the normal one must satisfy too (`reconf check` says so, RC112). Declare
        before `Component.start()`, as `set_normal_mode`. Returns the functionality;
        DeclarationError as for `set_normal_mode`."""
        self._mode(self.degraded, callback, rate, outputs)
        return self

    def mode(self, kind: str) -> Mode:
        """The normal mode for "normal", the degraded one for anything else."""
        return self.normal if kind == "normal" else self.degraded


class Component:
    """A component: one lifecycle node named after it (docs/control-interface.md).

    Declared in Python, no ROS needed: its ports, functionalities and modes are its model, which
    `to_arch` prints and `reconf` checks and plans with. `start()` runs it. Declare everything
    before it starts. `Component(name, run=, host=, replaces=)`: DeclarationError for a name that
    is not a valid node name.

        comp = Component("talker")
        out = comp.create_output("out", "std_msgs/msg/String")
        talk = comp.create_functionality("talk", outputs=[out])
        talk.set_normal_mode(lambda: out.write(out.new(data="hello")), rate=10, outputs=[out])
        talk.set_degraded_mode()
        comp.start()
    """

    def __init__(self, name: str, *, run: Optional[str] = None, host: Optional[str] = None,
                 replaces: Optional[str] = None) -> None:
        if not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise DeclarationError(f"{name!r} is not a valid component (node) name")
        self.name, self.run, self.host, self.replaces = name, run, host, replaces
        self.ports: list[Port] = []
        self.functionalities: list[Functionality] = []
        self.extra_messages: dict[str, str] = {}
        self.timers: list[tuple[Rate, Callable[[], None]]] = []
        self.reports: dict[str, Callable[[], str]] = {}
        self.lean = False         # serve only the control interface's four services (docs/runtime.md#cost)
        self.node_name: Optional[str] = None    # the node's name when not the component's (docs/executor.md#names)
        self.node: Any = None     # the running ComponentNode, once started
        # Not a reconf node: the architecture's `node` block (its IR, and its canonical lines), which
        # an adapter runs (reconf_ros.nodes.adapter, docs/adapter.md).
        self.wraps: Any = None
        self.node_block: list[str] = []

    # --- the API of paper 001 §5.2 ---
    def create_input(self, name: str, msg_type: MsgType, rate: RateLike = None, *,
                     alias: Optional[str] = None, service: bool = False, durable: Optional[bool] = None,
                     on_demand: Optional[bool] = None) -> Input:
        """A subscriber (`service=True`: the client side of a service, see `Input.request`; its
        replies are on demand unless `on_demand=False`).

        Its assumption is `msg_type` at `rate` (None: any rate), the type named `alias` (default:
        the type's last part). It subscribes to nothing until a plan attaches it (paper 001 §5.2:
        the framework attaches). DeclarationError for a name that is not valid or taken, a type
        that is not a ROS type, or a rate that is not one."""
        t = ros_type_name(msg_type)
        a = alias or t.rsplit("/", 1)[1]
        port = Input(self, self._fresh(name), t, a, assumption=Predicate(a, to_rate(rate)), service=service,
                     durable=not service if durable is None else durable,
                     on_demand=service if on_demand is None else on_demand)
        self.ports.append(port)
        return port

    def create_output(self, name: str, msg_type: MsgType, *, alias: Optional[str] = None, service: bool = False,
                      durable: Optional[bool] = None) -> Output:
        """A publisher (`service=True`: the server side of a service, see `Output.on_request`).
        Data is durable (transient-local) unless `durable=False`; a service's replies are not.
        What it guarantees is said by the modes that name it; it publishes nothing until a plan
        attaches it. DeclarationError as for `create_input`."""
        t = ros_type_name(msg_type)
        port = Output(self, self._fresh(name), t, alias or t.rsplit("/", 1)[1], service=service,
                      durable=not service if durable is None else durable)
        self.ports.append(port)
        return port

    def create_timer(self, rate: RateLike, callback: Callable[[], None]) -> None:
        """Run `callback` at `rate` while the node is active, whatever the modes: the application's
        own activity, such as a client sending requests (a mode's timer is `set_normal_mode`).
        `rate` must be given; DeclarationError for one that is not a rate."""
        r = to_rate(rate)
        assert r is not None
        self.timers.append((r, callback))

    def report(self, key: str, value: Callable[[], str]) -> None:
        """Publish `value()` under `app.<key>` in the node's status: what the application observes
        of itself, such as a detector's current silence limit."""
        self.reports[f"app.{key}"] = value

    def in_flight(self, functionality: str, count: Callable[[], int]) -> None:
        """Publish `count()` under `in_flight.<functionality>` in the node's status: how many
        requests the functionality has passed on and not yet had answered. A plan's `degrade`
        of it completes only once its status shows it degraded with none in flight
        (docs/control-interface.md#the-six-actions); call `changed` when the count falls to 0."""
        self.reports[f"in_flight.{functionality}"] = lambda: str(count())

    def changed(self) -> None:
        """Publish the node's status soon: something `report` or `in_flight` shows has changed."""
        if self.node is not None:
            self.node.status_changed()

    def create_functionality(self, name: str, inputs: Sequence[Input] = (), outputs: Sequence[Output] = (),
                             criticality: int = 1) -> Functionality:
        """A functionality associated with `inputs` and `outputs` (ports of this component), of
        weight `criticality` in a plan's disruption. Until its modes are set, its normal mode
        assumes what its inputs assume and guarantees nothing, and its degraded mode assumes and
        guarantees nothing. DeclarationError for a name it already has, or a port of another
        component."""
        if any(f.name == name for f in self.functionalities):
            raise DeclarationError(f"{self.name} already has a functionality {name}")
        for p in list(inputs) + list(outputs):
            if p not in self.ports:
                raise DeclarationError(f"{self.name}.{name}: {p.name} is not a port of {self.name}")
        f = Functionality(self, name, inputs, outputs, criticality)
        self.functionalities.append(f)
        return f

    def message(self, alias: str, msg_type: MsgType) -> str:
        """Name a message type that only an assumption uses (e.g. an environment's camera)."""
        self.extra_messages[alias] = ros_type_name(msg_type)
        return alias

    def start(self, args: Optional[list[str]] = None, **options: Any) -> int:
        """Bring the component up as a lifecycle node and spin until it is shut down: it waits
        unconfigured for a plan's `create` (or, with `deployed=`, comes up as deployed).
        `run_components([self], args=args, **options)`: needs rclpy, initialises it (once per
        process) and returns 0 when the node is finalized or the process is signalled."""
        from .component import run_components
        return run_components([self], args=args, **options)

    # --- the model ---
    def _fresh(self, name: str) -> str:
        if not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise DeclarationError(f"{name!r} is not a valid port name")
        if any(p.name == name for p in self.ports):
            raise DeclarationError(f"{self.name} already has a port {name}")
        return name

    def port(self, name: str) -> Port:
        """The port `name`; DeclarationError when the component has none of that name."""
        for p in self.ports:
            if p.name == name:
                return p
        raise DeclarationError(f"{self.name} has no port {name}")

    @property
    def inputs(self) -> list[Input]:
        """The input ports, in declaration order."""
        return [p for p in self.ports if isinstance(p, Input)]

    @property
    def outputs(self) -> list[Output]:
        """The output ports, in declaration order."""
        return [p for p in self.ports if isinstance(p, Output)]

    def messages(self) -> dict[str, str]:
        """alias -> ROS type of every port and of the types named by `message`; DeclarationError
        when one alias names two types."""
        out: dict[str, str] = dict(self.extra_messages)
        for p in self.ports:
            if out.setdefault(p.alias, p.msg_type) != p.msg_type:
                raise DeclarationError(f"{self.name}: {p.alias} names both {out[p.alias]} and {p.msg_type}")
        return out

    def to_arch(self) -> str:
        """The component as `.arch` text (docs/runtime.md): what `reconf` checks and plans with."""
        lines = [f"component {self.name}" + (f" replaces {self.replaces}" if self.replaces else "") + " {"]
        if self.run:
            lines.append(f"  run {_quote(self.run)}")
        if self.host:
            lines.append(f"  host {self.host}")
        lines.extend(f"  {line}" for line in self.node_block)
        for p in self.ports:
            if isinstance(p, Input):
                lines.append(f"  input {p.name}: {p.assumption}")
            else:
                lines.append(f"  output {p.name}: {p.alias}")
        for f in self.functionalities:
            crit = f" criticality {f.criticality}" if f.criticality != 1 else ""
            lines.append("")
            lines.append(f"  functionality {f.name} ({', '.join(f.ports)}){crit} {{")
            for mode in (f.normal, f.degraded):
                body = [f"assume {a}" for a in (mode.assumes if mode.kind == "normal" else [])]
                for out in f.outputs:
                    if out.name in mode.guarantees:
                        r = mode.guarantees[out.name]
                        body.append(f"{out.name}: {out.alias}" + (f" @ {r}" if r is not None else ""))
                    else:
                        body.append(f"{out.name}: nothing")
                if not body:
                    lines.append(f"    {mode.kind} {{ }}")
                elif len(body) == 1:
                    lines.append(f"    {mode.kind} {{ {body[0]} }}")
                else:
                    lines.append(f"    {mode.kind} {{")
                    lines.extend(f"      {b}" for b in body)
                    lines.append("    }")
            lines.append("  }")
        lines.append("}")
        return "\n".join(lines) + "\n"


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def components_to_arch(components: Sequence[Component], system: Optional[str] = None) -> str:
    """Message declarations and component blocks of several components, as one `.arch` text;
    DeclarationError when one alias names two types across them."""
    messages: dict[str, str] = {}
    for c in components:
        for alias, t in c.messages().items():
            if messages.setdefault(alias, t) != t:
                raise DeclarationError(f"{alias} names both {messages[alias]} and {t}")
    head = [f"system {system}", ""] if system else []
    head += [f"message {a} = {t}" for a, t in sorted(messages.items())]
    return "\n".join(head) + "\n\n" + "\n".join(c.to_arch() for c in components)
