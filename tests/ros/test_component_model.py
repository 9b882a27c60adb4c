"""The Component API's model half (no ROS needed): the demo nodes are the examples' components,
written once next to the code; the monitor's rule of docs/runtime.md."""
from __future__ import annotations

import importlib
import shlex

import pytest

from reconf_dsl.ir import Component as IrComponent
from reconf_dsl.ir import System
from reconf_dsl.loader import load, load_text
from reconf_ros import Component, components_to_arch
from reconf_ros.nodes.api import DeclarationError, parse_predicate
from reconf_ros.nodes.monitor import Monitor

from .conftest import example

EXAMPLES = ["chatter.arch", "chatter_migrated.arch", "robot.arch", "redundant.arch", "chain5.arch"]


def normal_form(c: IrComponent, system: System) -> tuple[object, ...]:
    """What the model says of a component, rates in hertz (`@ 1 s` is `@ 1 Hz`)."""
    types = {m.name: m.ros_type for m in system.messages}

    def pred(p: object) -> object:
        return None if p is None else (getattr(p, "message"), getattr(p, "hz"))
    ports = tuple((p.name, p.kind, types[p.message], pred(p.assumption)) for p in c.ports)
    funcs = tuple((f.name, f.ports, f.criticality,
                   tuple((m.kind, tuple(pred(a) for a in m.assumptions),
                          tuple((g.port, pred(g.predicate)) for g in m.guarantees if not g.predicate.is_nothing))
                         for m in (f.normal, f.degraded) if m is not None))
                  for f in c.functionalities)
    return (c.name, c.host, ports, funcs)


def factory(run: str) -> Component:
    target = shlex.split(run)[1]
    module, attr = target.split(":")
    comp: Component = getattr(importlib.import_module(module), attr)()
    return comp


@pytest.mark.parametrize("name", EXAMPLES)
def test_demo_nodes_are_the_examples_components(name: str) -> None:
    system = load([example(name)])
    for c in system.components + system.versions:
        assert c.run and c.run.startswith("reconf-node "), c.name
        comp = factory(c.run)
        assert comp.replaces == c.replaces, c.name
        comp.replaces = None          # a version alone would replace an unknown component
        text = components_to_arch([comp], system="check")
        mine = load_text(text).component(c.name)
        assert mine is not None
        assert normal_form(mine, load_text(text)) == normal_form(c, system), text


def test_a_system_assembled_from_nodes_checks() -> None:
    from reconf_ros.demo import chatter
    text = components_to_arch([chatter.talker(), chatter.listener()], system="chatter")
    text += "topic /chatter: String @ 10 Hz { talker.out -> listener.in }\n"
    from checker.semantic_model.config import Configuration
    from checker.semantic_model.semantics import evaluate
    system = load_text(text)
    assert not evaluate(system, Configuration.initial(system), explain=False).unsatisfied


def test_model_errors_are_clear() -> None:
    comp = Component("c")
    with pytest.raises(DeclarationError, match="not a ROS 2 type name"):
        comp.create_output("o", "String")
    out = comp.create_output("o", "std_msgs/msg/String")
    with pytest.raises(DeclarationError, match="already has a port o"):
        comp.create_input("o", "std_msgs/msg/String")
    f = comp.create_functionality("f", outputs=[out])
    with pytest.raises(DeclarationError, match="a rate must be positive"):
        f.set_normal_mode(None, rate=0, outputs=[out])
    with pytest.raises(DeclarationError, match="not a predicate"):
        parse_predicate("@ 10 Hz")


def test_monitor_rule() -> None:
    comp = Component("listener")
    inp = comp.create_input("in", "std_msgs/msg/String", rate=10)
    f = comp.create_functionality("listen", inputs=[inp])
    f.set_normal_mode(lambda msg: None)
    m = Monitor(comp, gap_factor=1.5)
    attached = {"in": ["/chatter"]}
    assert m.judge(f, 0.0, {"in": []}).startswith("not met: in is attached to nothing")
    m.on_message("in", 1.0, b"a", 1, "talker")
    assert m.check(1.1, {"listen": "normal"}, attached) and m.verdicts["listen"] == "met"
    m.on_message("in", 1.2, b"a", 2, "talker")
    m.check(1.34, {"listen": "normal"}, attached)
    assert m.violations == 0
    m.check(1.36, {"listen": "normal"}, attached, grace=0.05)   # a timer allows for its own delay
    assert m.violations == 0
    m.check(1.36, {"listen": "normal"}, attached)            # 0.16 s > 1.5 x 0.1 s
    assert m.violations == 1 and m.verdicts["listen"].startswith("not met")
    m.on_message("in", 1.4, b"a", 5, "talker")               # two messages of talker lost
    m.check(1.4, {"listen": "normal"}, attached)
    assert m.violations == 1 and not m.violating
    st = m.status(1.4)
    assert st["in.in.lost"] == "2" and st["in.in.from.talker"] == "3/2/0"
    assert float(st["in.in.max_gap_s"]) == pytest.approx(0.2, abs=1e-6)
    m.on_message("in", 1.45, b"b", 7, "talker_v2")           # a new publisher, first seen at its 7th
    assert m.status(1.45)["in.in.from.talker_v2"] == "1/0/6"
    m.check(3.0, {"listen": "degraded"}, attached)           # degraded: no violation
    assert m.violations == 1


def test_a_timer_ahead_of_a_message_on_time_is_withdrawn() -> None:
    """A timer may judge a silence while a message that arrived in time waits for its callback;
    the arrival withdraws that provisional violation, and a real gap is still counted."""
    comp = Component("listener")
    inp = comp.create_input("in", "std_msgs/msg/String", rate=10)
    f = comp.create_functionality("listen", inputs=[inp])
    f.set_normal_mode(lambda msg: None)
    m = Monitor(comp, gap_factor=1.5)
    attached, normal = {"in": ["/chatter"]}, {"listen": "normal"}
    m.on_message("in", 1.0, b"a", 1, "talker")
    m.check(1.0, normal, attached)
    m.check(1.25, normal, attached, grace=0.05)               # the timer: 0.25 s > 0.15 + 0.05
    assert m.violations == 1 and m.violating
    m.check(1.14, normal, attached)                           # ... but a message came at 1.14
    m.on_message("in", 1.14, b"a", 2, "talker")
    assert m.violations == 0 and not m.violating and m.history == []
    assert "last_violation" not in m.status(1.14)
    m.check(1.5, normal, attached, grace=0.05)                # a real silence: provisional ...
    m.check(1.6, normal, attached)                            # ... confirmed by the arrival at 1.6
    m.on_message("in", 1.6, b"a", 3, "talker")
    m.check(1.6, normal, attached)
    assert m.violations == 1 and not m.violating and m.violation_seconds == pytest.approx(0.1)
    assert m.status(1.6)["last_violation"].startswith("1.500 listen: not met")


def test_a_publisher_named_after_its_first_message() -> None:
    """Transient-local data can arrive before discovery names the publisher's node: the source
    is named as soon as it is known, so the executor sees data from the node it attached."""
    comp = Component("listener")
    inp = comp.create_input("in", "std_msgs/msg/String", rate=10)
    comp.create_functionality("listen", inputs=[inp]).set_normal_mode(lambda msg: None)
    m = Monitor(comp)
    m.on_message("in", 1.0, b"g", 1, "?")
    m.on_message("in", 1.1, b"g", 2, "talker_v2")
    st = m.status(1.1)
    assert st["in.in.from.talker_v2"] == "2/0/0" and "in.in.from.?" not in st
    assert m.fresh_sources("in", 1.1) == ["talker_v2"]


def test_an_on_demand_input_owes_its_rate_only_while_asked() -> None:
    """A service's replies (or a pipeline's results) come as fast as requests are made: silence
    with nothing asked is no violation; a request unanswered beyond k/r is one."""
    comp = Component("client")
    reply = comp.create_input("reply", "std_msgs/msg/String", rate=10, service=True)
    assert reply.on_demand and not comp.create_input("other", "std_msgs/msg/String", rate=10).on_demand
    f = comp.create_functionality("use", inputs=[reply])
    f.set_normal_mode()
    m = Monitor(comp, gap_factor=1.5)
    attached, normal = {"reply": ["/compute"]}, {"use": "normal"}
    assert m.judge(f, 0.0, attached).startswith("not met: reply has no publisher")
    m.inputs["reply"].publishers["/compute"] = 1
    m.check(5.0, normal, attached)                     # matched, nothing asked: met, however long
    assert m.violations == 0 and m.verdicts["use"] == "met"
    m.expect("reply", 5.0)
    m.check(5.1, normal, attached)
    assert m.violations == 0
    m.on_message("reply", 5.12, b"s", 1, "server")     # answered in 0.12 s < 0.15 s
    m.expect("reply", 6.0)
    m.check(6.2, normal, attached)                     # asked 0.2 s ago, no answer
    assert m.violations == 1 and "waiting 0.200 s" in m.verdicts["use"]
    m.on_message("reply", 6.3, b"s", 2, "server")
    m.check(6.3, normal, attached)
    assert not m.violating and float(m.status(6.3)["in.reply.max_gap_s"]) == pytest.approx(0.3)
    # a burst of asks answered one by one at the rate meets it (a protocol resuming its queue)
    for _ in range(3):
        m.expect("reply", 7.0)
    for i, t in enumerate((7.1, 7.2, 7.3)):
        m.check(t, normal, attached)
        m.on_message("reply", t, b"s", 3 + i, "server")
    m.check(7.3, normal, attached)
    assert m.violations == 1 and not m.violating


def test_dds_env_points_at_the_shipped_loopback_profile() -> None:
    """`reconf-node --dds-env` (docs/runtime.md#dds): exports a shell can eval, naming a
    profile that exists and keeps Fast DDS to UDP on 127.0.0.1."""
    import shlex
    import xml.etree.ElementTree as ET

    from click.testing import CliRunner

    from reconf_ros.tools.runner import main as node_main
    result = CliRunner().invoke(node_main, ["--dds-env"])
    assert result.exit_code == 0, result.output
    env = dict(shlex.split(line)[1].split("=", 1) for line in result.output.splitlines())
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"
    ns = {"d": "http://www.eprosima.com"}
    root = ET.parse(env["FASTDDS_DEFAULT_PROFILES_FILE"]).getroot()
    builtin = root.find(".//d:participant[@is_default_profile='true']//d:useBuiltinTransports", ns)
    assert builtin is not None and builtin.text == "false"
    assert {a.text for a in root.findall(".//d:address", ns)} == {"127.0.0.1"}
    assert [t.text for t in root.findall(".//d:transport_descriptor/d:type", ns)] == ["UDPv4"]


def test_the_executor_reads_the_announcement_period_from_the_profile(tmp_path: Path) -> None:
    """The discovery round of a plan (docs/executor.md#discovery) is the announcement period of
    the profile the process runs under and a margin: the shipped loopback profile's 0.25 s, a
    profile's own, or Fast DDS's 3 s where none says."""
    from reconf_ros.executor.runtime import FAST_DDS_ANNOUNCEMENT, announcement_period
    from reconf_ros.nodes.dds import PROFILE, loopback_env
    assert announcement_period(loopback_env()) == 0.25
    assert announcement_period({}) == FAST_DDS_ANNOUNCEMENT == 3.0
    own = tmp_path / "own.xml"
    own.write_text(PROFILE.read_text(encoding="utf-8").replace("<nanosec>250000000</nanosec>", "<nanosec>0</nanosec>")
                   .replace("<sec>0</sec>", "<sec>1</sec>"), encoding="utf-8")
    assert announcement_period({"FASTDDS_DEFAULT_PROFILES_FILE": str(own)}) == 1.0
    assert announcement_period({"FASTDDS_DEFAULT_PROFILES_FILE": str(tmp_path / "missing.xml")}) == 3.0
