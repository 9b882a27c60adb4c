"""A chain of five stages, each needing the one before it (examples/chain5.arch)."""
from __future__ import annotations

from reconf_ros import Component

DATA = "std_msgs/msg/Float64"
RATES = [20, 18, 16, 14, 12, 10]     # the sensor's, then each stage's output


def _stage(i: int, name: str | None = None, replaces: str | None = None) -> Component:
    comp = Component(name or f"stage{i}", replaces=replaces)
    out = comp.create_output("out", DATA, alias="Data")
    if i == 0:   # the sensor is the environment's, and its readings are a type of their own
        comp.message("Reading", DATA)
        step = comp.create_functionality("step", outputs=[out])
        step.set_normal_mode(lambda: out.write(out.new(data=1.0)), rate=RATES[1], outputs=[out],
                             assumes=[f"Reading @ {RATES[0]} Hz"])
    else:
        inp = comp.create_input("in", DATA, rate=RATES[i], alias="Data")
        comp.ports.reverse()   # the architecture lists the input first
        step = comp.create_functionality("step", inputs=[inp], outputs=[out])

        def forward() -> None:
            last = inp.read()
            out.write(out.new(data=(last.data if last is not None else 0.0) + 1.0))

        step.set_normal_mode(forward, rate=RATES[i + 1], outputs=[out])
    step.set_degraded_mode()
    return comp


def stage0() -> Component:
    return _stage(0)


def stage0_v2() -> Component:
    return _stage(0, "stage0_v2", replaces="stage0")


def stage1() -> Component:
    return _stage(1)


def stage2() -> Component:
    return _stage(2)


def stage3() -> Component:
    return _stage(3)


def stage4() -> Component:
    return _stage(4)
