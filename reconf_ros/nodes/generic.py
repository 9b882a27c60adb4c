"""Model-driven nodes: a Component built from a component of an architecture, whose behaviour
is its model (docs/runtime.md): each mode publishes a default message of every output it
guarantees, at the guaranteed rate, and reads its inputs. For generated systems (benchmarks)
and for trying a plan before the real nodes exist."""
from __future__ import annotations

from fractions import Fraction
from typing import Any, Optional

from reconf_dsl.ir import Component as IrComponent
from reconf_dsl.ir import Predicate as IrPredicate
from reconf_dsl.ir import System

from .api import Component, Output, Rate

__all__ = ["from_architecture"]

DEFAULT_HZ = Fraction(10)


def _rate(p: IrPredicate) -> Optional[Rate]:
    return None if p.rate is None else Rate(p.rate.value, p.rate.unit)


def _publisher(outputs: list[Output]) -> Any:
    def publish() -> None:
        for out in outputs:
            out.write(out.new())
    return publish


def from_architecture(system: System, name: str, behaviour: bool = True) -> Component:
    """The component `name` of `system` (deployed or a version) as a model-driven Component;
    without `behaviour`, its model alone (an adapter's: the node it drives behaves)."""
    ir: Optional[IrComponent] = system.component(name)
    if ir is None:
        raise KeyError(f"{system.name} declares no component {name}")
    types = {m.name: m.ros_type for m in system.messages}
    comp = Component(ir.name, run=ir.run, host=ir.host, replaces=ir.replaces)
    served = service_ports(system, ir.replaces or ir.name) | service_ports(system, ir.name)
    ports: dict[str, Any] = {}
    for p in ir.ports:
        if p.kind == "input":
            a = p.assumption
            ports[p.name] = comp.create_input(p.name, types[p.message], None if a is None else _rate(a),
                                              alias=p.message, service=p.name in served)
        else:
            ports[p.name] = comp.create_output(p.name, types[p.message], alias=p.message, service=p.name in served)
    for f in ir.functionalities:
        fn = comp.create_functionality(f.name, inputs=[ports[n] for n in f.ports if ports[n].kind == "input"],
                                       outputs=[ports[n] for n in f.ports if ports[n].kind == "output"],
                                       criticality=f.criticality)
        for mode, setter in ((f.normal, fn.set_normal_mode), (f.degraded, fn.set_degraded_mode)):
            if mode is None:
                continue
            gs: dict[Output, Any] = {ports[g.port]: _rate(g.predicate) for g in mode.guarantees
                                     if not g.predicate.is_nothing}
            hz = max((r.hz for r in gs.values() if r is not None), default=DEFAULT_HZ)
            callback = _publisher(list(gs)) if gs and behaviour else None
            for a in mode.assumptions:      # an environment's type (no port has it) is in the model too
                if a.message in types:
                    comp.message(a.message, types[a.message])
            if mode.kind == "normal":
                fn.set_normal_mode(callback, rate=hz if gs else None, outputs=gs,
                                   assumes=[str(a) for a in mode.assumptions])
            else:
                fn.set_degraded_mode(callback, rate=hz if gs else None, outputs=gs)
    if behaviour:
        from .ftm import install
        install(comp, system)
    return comp


def service_ports(system: System, component: str) -> set[str]:
    """The ports of `component` that `system` attaches to a service."""
    return {r.port for c in system.connectors if c.kind == "service" for r in c.roles if r.component == component}
