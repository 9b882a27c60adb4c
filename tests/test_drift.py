"""`reconf drift` and `reconf discover` without ROS: the comparison and the writing over
hand-made snapshots of the running system, every kind of difference at its span, and the
commands on saved snapshots (exit codes, output formats)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from checker.reality.discover import architecture
from checker.reality.drift import drift
from reconf_dsl.loader import load, load_text
from reconf_ros.executor.snapshot import NodeInfo, Snapshot
from reconf_ros.nodes.api import components_to_arch

ROOT = Path(__file__).resolve().parents[1]
CHATTER = str(ROOT / "examples" / "chatter.arch")
ROBOT = str(ROOT / "examples" / "robot.arch")
STRING = "std_msgs/msg/String"


def deployed(path: str) -> Snapshot:
    """The system as its model deploys it: every component's node active, normal, attached as declared."""
    from reconf_ros.nodes.generic import from_architecture
    system = load([path])
    types = {m.name: m.ros_type for m in system.messages}
    snap = Snapshot()
    for c in system.components:
        node = NodeInfo(f"/{c.name}", lifecycle="active", component=c.name,
                        model=components_to_arch([from_architecture(system, c.name)]))
        node.modes = {f.name: "normal" for f in c.functionalities}
        node.ports = {p.name: [] for p in c.ports}
        snap.nodes[node.fqn] = node
    for conn in system.connectors:
        t = types[conn.guarantee.message or ""]
        snap.topics[conn.name] = [t]
        for r in conn.roles:
            node = snap.nodes[f"/{r.component}"]
            node.ports[r.port].append(conn.name)
            side = node.publishers if r in conn.publishers else node.subscribers
            side[conn.name] = [t]
    return snap


def codes(path: str, snap: Snapshot) -> list[tuple[str, int]]:
    return [(d.code, d.span.line) for d in drift(load([path]), snap)]


def test_a_system_as_deployed_has_no_drift() -> None:
    assert codes(CHATTER, deployed(CHATTER)) == []
    assert codes(ROBOT, deployed(ROBOT)) == []


def test_a_missing_component_is_reported_at_its_declaration() -> None:
    snap = deployed(CHATTER)
    del snap.nodes["/listener"]
    assert codes(CHATTER, snap) == [("RC611", 30)]


def test_an_extra_node_is_reported_and_a_tool_node_is_not() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/spy"] = NodeInfo("/spy", subscribers={"/chatter": [STRING]})
    snap.nodes["/reconf_watch_1"] = NodeInfo("/reconf_watch_1")          # no topic of the application
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC612", 3) and "/spy" in d.message and "it subscribes to /chatter" in d.notes


def test_a_version_running_is_extra_and_named_as_such() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/talker_v2"] = NodeInfo("/talker_v2", component="talker_v2", lifecycle="active", model="x")
    [d] = drift(load([CHATTER]), snap)
    assert d.code == "RC612" and "a version of the model" in d.message


def test_a_port_attached_elsewhere_is_one_difference_at_its_role() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/talker"].ports["out"] = ["/other"]
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC613", 42)
    assert "attached to /other (not a connector of the model), where the model attaches it to /chatter" in d.message


def test_a_port_detached_or_attached_twice() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/listener"].ports["in"] = []
    assert codes(CHATTER, snap) == [("RC613", 42)]
    snap.nodes["/listener"].ports["in"] = ["/chatter", "/extra"]
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC613", 33) and "attached to /extra" in d.message


def test_a_plain_node_is_compared_by_its_topics() -> None:
    """Its modes and attachments cannot be read, and drift says so (RC619, never "in sync");
    its topics are still compared."""
    snap = deployed(CHATTER)
    node = snap.nodes["/listener"]
    node.model, node.ports, node.modes, node.lifecycle = None, {}, {}, None
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC619", 30) and "cannot be read" in d.message, d
    assert "declare how reconf drives it" in d.notes[0]
    node.subscribers = {"/elsewhere": [STRING]}
    assert [c for c, _ in codes(CHATTER, snap)] == ["RC619", "RC613"]


def test_a_message_type_that_differs() -> None:
    snap = deployed(CHATTER)
    snap.topics["/chatter"] = ["std_msgs/msg/Int32"]
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC614", 41) and "std_msgs/msg/Int32" in d.message


def test_a_degraded_functionality() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/listener"].modes["listen"] = "degraded"
    assert codes(CHATTER, snap) == [("RC615", 35)]


def test_a_second_publisher_on_a_single_topic(tmp_path: Path) -> None:
    arch = tmp_path / "single.arch"
    arch.write_text(Path(CHATTER).read_text().replace("topic /chatter: String @ 10 Hz {",
                                                      "topic /chatter: String @ 10 Hz single {"))
    snap = deployed(str(arch))
    assert codes(str(arch), snap) == []
    snap.nodes["/intruder"] = NodeInfo("/intruder", publishers={"/chatter": [STRING]})
    assert sorted(c for c, _ in codes(str(arch), snap)) == ["RC612", "RC616"]


def test_a_node_not_active() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/talker"].lifecycle = "inactive"
    snap.nodes["/talker"].ports["out"] = []        # an inactive node is isolated: said once, not per port
    assert codes(CHATTER, snap) == [("RC617", 7)]


def test_a_new_version_under_another_node_name_is_found_by_what_it_declares() -> None:
    snap = deployed(CHATTER)
    node = snap.nodes.pop("/talker")
    node.fqn = "/talker_2"
    snap.nodes["/talker_2"] = node
    assert codes(CHATTER, snap) == []


def test_discovery_of_the_deployed_system_reads_back_as_the_model() -> None:
    system = load([CHATTER])
    found = load_text(architecture(deployed(CHATTER), "chatter"), "<discovered>")
    assert sorted(c.name for c in found.components) == sorted(c.name for c in system.components)
    for c in system.components:
        assert found.component(c.name) == c
    assert found.connectors == system.connectors


def test_a_plain_node_is_a_placeholder_component() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/counter"] = NodeInfo("/counter", publishers={"/heard": ["std_msgs/msg/Int32"]},
                                      subscribers={"/chatter": [STRING]})
    text = architecture(snap, "chatter")
    found = load_text(text, "<discovered>")
    counter = found.component("counter")
    assert counter is not None
    assert [(p.name, p.kind, p.message) for p in counter.ports] == [("heard", "output", "Int32"),
                                                                    ("chatter", "input", "String")]
    assert [f.name for f in counter.functionalities] == ["main"]
    assert "// placeholder: node /counter has no reconf.model" in text
    assert "// placeholder: /heard: no publisher's model gives a rate" in text
    chatter = found.connector("/chatter")
    assert chatter is not None and [str(r) for r in chatter.subscribers] == ["counter.chatter", "listener.in"]
    # how reconf drives it (docs/adapter.md): its real name and topics, a plain node's outputs held
    assert counter.node is not None and (counter.node.name, counter.node.lifecycle) == ("counter", False)
    assert {t.port: t.ros_name for t in counter.node.topics} == {"heard": "/heard", "chatter": "/chatter"}
    assert [str(e.kind) for e in counter.node.effects("main", "degraded")] == ["hold"]
    assert "add the `run` line that starts it" in text


def test_a_lifecycle_node_is_written_to_be_deactivated_and_a_node_with_services_undriven() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/camera"] = NodeInfo("/camera", publishers={"/image": ["sensor_msgs/msg/Image"]}, lifecycle="active")
    snap.nodes["/adder"] = NodeInfo("/adder", servers={"/add": ["example_interfaces/srv/AddTwoInts"]})
    found = load_text(architecture(snap, "chatter"), "<discovered>")
    camera, adder = found.component("camera"), found.component("adder")
    assert camera is not None and camera.node is not None and camera.node.lifecycle
    assert [e.kind for e in camera.node.effects("main", "degraded")] == ["deactivate"]
    assert adder is not None and adder.node is None         # an adapter relays topics, not services


SLOW = str(ROOT / "examples" / "chatter_slow.arch")
UNPUBLISHED = str(ROOT / "examples" / "chatter_unpublished.arch")


def test_a_node_running_another_model_is_rc618_saying_what_differs() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/talker"].model = deployed(SLOW).nodes["/talker"].model
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC618", 7)
    assert "functionality talk: the model has (out) normal {out: std_msgs/msg/String @ 10 Hz}" in d.message
    assert "the node (out) normal {out: std_msgs/msg/String @ 5 Hz}" in d.message
    snap.nodes["/talker"].model = "component talker {"      # not a model at all
    [d] = drift(load([CHATTER]), snap)
    assert d.code == "RC618" and "does not parse" in d.message


def test_the_same_model_with_other_aliases_and_units_is_no_drift() -> None:
    snap = deployed(CHATTER)
    node = snap.nodes["/talker"]
    node.model = (node.model or "").replace("String", "Text").replace("msg/Text", "msg/String") \
        .replace("10 Hz", "100 ms")
    assert "message Text = std_msgs/msg/String" in node.model and "Text @ 100 ms" in node.model
    assert codes(CHATTER, snap) == []


def test_a_node_that_does_not_answer_is_rc617_and_nothing_else() -> None:
    snap = deployed(CHATTER)
    node = snap.nodes["/listener"]
    node.model, node.ports, node.modes = None, {}, {}
    node.unanswered = "reconf.model: no answer from /listener/get_parameters within 5.0 s"
    [d] = drift(load([CHATTER]), snap)
    assert (d.code, d.span.line) == ("RC617", 30) and "does not answer (reconf.model: no answer" in d.message
    text = architecture(snap, "chatter")
    assert "// placeholder: node /listener did not answer (reconf.model: no answer" in text
    load_text(text, "<discovered>")


def test_drift_compares_with_what_reconf_up_brings_about() -> None:
    snap = deployed(UNPUBLISHED)              # listen can only be degraded: nobody publishes /chatter
    assert codes(UNPUBLISHED, snap) == [("RC615", 10)]
    [d] = drift(load([UNPUBLISHED]), snap)
    assert "is normal live; the deployed configuration has it degraded" in d.message
    snap.nodes["/listener"].modes["listen"] = "degraded"
    assert codes(UNPUBLISHED, snap) == []
    from checker.reality.drift import deployed as expected
    _, notes = expected(load([UNPUBLISHED]))
    assert notes == ["listener.listen is degraded as deployed: it assumes String @ 10 Hz, which cannot hold there"]


def test_tool_nodes_and_clients_of_standard_services_are_not_the_application() -> None:
    from reconf_ros.executor.snapshot import _application
    from reconf_ros.executor.status import tool_node
    assert tool_node("watch").startswith("_reconf_watch_")          # hidden: the graph reader skips it
    assert _application({"/talker/get_parameters": ["rcl_interfaces/srv/GetParameters"],
                         "/listener/get_state": ["lifecycle_msgs/srv/GetState"],
                         "/add": ["example_interfaces/srv/AddTwoInts"]}) == {
        "/add": ["example_interfaces/srv/AddTwoInts"]}


def test_a_namespaced_snapshot_is_compared_in_its_namespace() -> None:
    snap = deployed(CHATTER)
    snap.namespace = "/robot"
    snap.nodes = {f"/robot{k}": n for k, n in snap.nodes.items()}
    for n in snap.nodes.values():
        n.fqn = f"/robot{n.fqn}"
    assert codes(CHATTER, snap) == []
    snap.nodes["/listener"] = snap.nodes.pop("/robot/listener")     # in another namespace: not this system's
    snap.nodes["/listener"].component = None
    assert ("RC611", 30) in codes(CHATTER, snap)


SERVICE = """system adder
message Sum = example_interfaces/srv/AddTwoInts
component server {
  output sum: Sum
  functionality serve (sum) { normal { sum: Sum } degraded { sum: nothing } }
}
component client {
  input ask: Sum
  functionality use (ask) { normal { assume Sum } degraded { } }
}
service /add: Sum { server.sum -> client.ask }
"""


def test_services_plain_servers_count_as_publishers_and_their_type_is_compared(tmp_path: Path) -> None:
    arch = tmp_path / "adder.arch"
    arch.write_text(SERVICE)
    srv = ["example_interfaces/srv/AddTwoInts"]
    snap = Snapshot(nodes={"/server": NodeInfo("/server", servers={"/add": srv}),
                           "/client": NodeInfo("/client", clients={"/add": srv})})

    def found() -> list[str]:       # beside RC619 for each, whose modes cannot be read
        got = [c for c, _ in codes(str(arch), snap)]
        assert got.count("RC619") == len({"/server", "/client"} & set(snap.nodes)), got
        return sorted(c for c in got if c != "RC619")
    assert found() == []
    snap.nodes["/other"] = NodeInfo("/other", servers={"/add": srv})
    assert found() == ["RC612", "RC616"]
    del snap.nodes["/other"]
    snap.nodes["/server"].servers["/add"] = ["example_interfaces/srv/Trigger"]
    snap.nodes["/client"].clients["/add"] = ["example_interfaces/srv/Trigger"]
    assert found() == ["RC614"]
    del snap.nodes["/server"]
    text = architecture(snap, "adder")
    assert "// placeholder: /add has clients and no server in the graph" in text


def test_one_ros_type_one_alias_whoever_names_it_first() -> None:
    snap = deployed(CHATTER)
    snap.nodes["/camera"] = NodeInfo("/camera", publishers={"/image": ["sensor_msgs/msg/Image"]})
    talker = snap.nodes["/talker"]         # a model naming another type Image, one naming String Text
    talker.model = (talker.model or "").replace("message String = std_msgs/msg/String",
                                                "message Image = my_msgs/msg/Image").replace("String", "Image")
    listener = snap.nodes["/listener"]
    listener.model = (listener.model or "").replace("String", "Text")
    snap.topics["/chatter"] = ["my_msgs/msg/Image"]
    for n in (talker, listener):
        for side in (n.publishers, n.subscribers):
            if "/chatter" in side:
                side["/chatter"] = ["my_msgs/msg/Image"]
    listener.model = listener.model.replace("std_msgs/msg/Text", "my_msgs/msg/Image")
    found = load_text(architecture(snap, "chatter"), "<discovered>")
    types = {m.name: m.ros_type for m in found.messages}
    assert sorted(types.values()) == ["my_msgs/msg/Image", "sensor_msgs/msg/Image"]       # one alias each
    camera, listen = found.component("camera"), found.component("listener")
    assert camera is not None and listen is not None
    assert types[camera.ports[0].message] == "sensor_msgs/msg/Image"
    assert types[listen.ports[0].message] == "my_msgs/msg/Image"


def reconf(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "checker", *args], capture_output=True, text=True, cwd=ROOT)


@pytest.fixture(scope="module")
def drifted(tmp_path_factory: pytest.TempPathFactory) -> str:
    snap = deployed(CHATTER)
    snap.nodes["/listener"].modes["listen"] = "degraded"
    path = tmp_path_factory.mktemp("drift") / "snap.json"
    path.write_text(snap.to_json())
    return str(path)


def test_the_command_exits_1_on_drift_with_every_format(drifted: str) -> None:
    res = reconf("drift", CHATTER, "--snapshot", drifted)
    assert res.returncode == 1 and "chatter.arch:35:3: error[RC615]" in res.stderr, res.stderr
    doc = json.loads(reconf("drift", CHATTER, "--snapshot", drifted, "--output-format", "json").stdout)
    assert doc["verdict"] == "drift" and [d["code"] for d in doc["diagnostics"]] == ["RC615"]
    sarif = json.loads(reconf("drift", CHATTER, "--snapshot", drifted, "--output-format", "sarif").stdout)
    [result] = sarif["runs"][0]["results"]
    assert result["ruleId"] == "RC615" and result["locations"][0]["physicalLocation"]["region"]["startLine"] == 35
    junit = reconf("drift", CHATTER, "--snapshot", drifted, "--output-format", "junit").stdout
    assert 'name="mode"' in junit and "<failure" in junit


def test_the_command_exits_0_in_sync_and_2_unanswered(tmp_path: Path) -> None:
    snap = tmp_path / "snap.json"
    snap.write_text(deployed(CHATTER).to_json())
    res = reconf("drift", CHATTER, "--snapshot", str(snap))
    assert res.returncode == 0 and "in sync" in res.stderr, res.stderr
    bad = reconf("drift", CHATTER, "--snapshot", str(tmp_path / "none.json"))
    assert bad.returncode == 2 and "RC602" in bad.stderr and "Traceback" not in bad.stderr
    worse = reconf("drift", str(tmp_path / "none.arch"), "--snapshot", str(snap))
    assert worse.returncode == 2 and "RC007" in worse.stderr


def test_discover_writes_an_arch_check_accepts_with_a_warning_per_placeholder(tmp_path: Path) -> None:
    snap = deployed(CHATTER)
    snap.nodes["/counter"] = NodeInfo("/counter", publishers={"/heard": ["std_msgs/msg/Int32"]})
    path = tmp_path / "snap.json"
    path.write_text(snap.to_json())
    out = tmp_path / "found.arch"
    res = reconf("discover", "--snapshot", str(path), "--system", "chatter", "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stderr.count("warning[RC601]") == 2 and f"{out}:6:1: warning[RC601]" in res.stderr
    check = reconf("check", "--engine", "python", str(out))
    assert check.returncode == 0, check.stderr
    assert reconf("fmt", "--check", str(out)).returncode == 0


def test_bad_snapshots_names_and_options_are_refused_clearly(tmp_path: Path) -> None:
    odd = tmp_path / "odd.json"
    odd.write_text("[1]")
    res = reconf("drift", CHATTER, "--snapshot", str(odd))
    assert res.returncode == 2 and "is not a snapshot" in res.stderr and "pip install" not in res.stderr, res.stderr
    snap = tmp_path / "snap.json"
    snap.write_text(deployed(CHATTER).to_json())
    res = reconf("drift", CHATTER, "--snapshot", str(snap), "--settle", "3")
    assert res.returncode == 2 and "--settle: read the live system, not a --snapshot" in res.stderr, res.stderr
    res = reconf("discover", "--snapshot", str(snap), "--system", "my sys")
    assert res.returncode == 2 and "'my sys' is not a system name" in res.stderr, res.stderr


def test_nothing_read_and_discovery_unsettled_is_not_an_answer(tmp_path: Path) -> None:
    empty = tmp_path / "empty.json"
    empty.write_text(Snapshot(settled=False).to_json())
    res = reconf("drift", CHATTER, "--snapshot", str(empty))
    assert res.returncode == 2 and "error[RC602]" in res.stderr, res.stderr
    assert "discovery did not settle and saw no node" in res.stderr
    other = Snapshot(settled=False, nodes={"/spy": NodeInfo("/spy", subscribers={"/chatter": [STRING]})})
    empty.write_text(other.to_json())
    res = reconf("drift", CHATTER, "--snapshot", str(empty))
    assert res.returncode == 2 and "saw none of the model's 2 nodes" in res.stderr, res.stderr
    assert "pip install" not in res.stderr      # a snapshot: nothing to install
