"""The talker/listener of paper 001 §5.2 (examples/chatter.arch, chatter_migrated.arch)."""
from __future__ import annotations

from reconf_ros import Component

STRING = "std_msgs/msg/String"


def _talker(name: str, hz: float = 10, replaces: str | None = None, host: str | None = "robot") -> Component:
    comp = Component(name, host=host, replaces=replaces)
    out = comp.create_output("out", STRING)
    talk = comp.create_functionality("talk", outputs=[out])
    count = [0]

    def normal() -> None:
        count[0] += 1
        out.write(out.new(data=f"hello from {name}: {count[0]}"))

    talk.set_normal_mode(normal, rate=hz, outputs=[out])
    talk.set_degraded_mode()          # silent while degraded
    return comp


def talker() -> Component:
    return _talker("talker")


def talker_v2() -> Component:
    return _talker("talker_v2", replaces="talker")


def talker_fast() -> Component:
    return _talker("talker_fast", hz=20, host=None)


def _listener(name: str, host: str | None = "robot") -> Component:
    comp = Component(name, host=host)
    inp = comp.create_input("in", STRING, rate=10)
    listen = comp.create_functionality("listen", inputs=[inp])

    def heard(msg) -> None:  # type: ignore[no-untyped-def]
        comp.node.get_logger().debug(f"heard {msg.data}")

    listen.set_normal_mode(heard)     # once per message
    listen.set_degraded_mode()
    return comp


def listener() -> Component:
    return _listener("listener")


def logger() -> Component:
    return _listener("logger", host=None)
