"""`reconf modes export|import`: SMH model files of ROS 2 system_modes (docs/modes.md).

Every exported system mode is read back from the YAML (part → node mode → its
`reconf.mode.<f>` parameters) and judged by the checker; imports are checked by `reconf check`."""
from __future__ import annotations

import glob
import json
import os
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner, Result

from checker.cli.main import main
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl.loader import Sources, load
from tests.examples_table import EXAMPLES, ROOT

DATA = os.path.join(ROOT, "tests", "data", "smh")
CHATTER = os.path.join(ROOT, "examples", "chatter.arch")
FUSION = os.path.join(DATA, "fusion.arch")
SMH_EXAMPLE = os.path.join(DATA, "example_modes.yaml")
ALL = sorted([e.file for e in EXAMPLES] + glob.glob(os.path.join(ROOT, "examples", "ftm", "*.arch")) + [FUSION])


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def exported(arch: str, tmp: Path, *extra: str) -> dict[str, Any]:
    out = tmp / "modes.yaml"
    r = run("modes", "export", arch, "-o", str(out), *extra)
    assert r.exit_code == 0, r.output
    doc = yaml.safe_load(out.read_text(encoding="utf-8"))
    assert isinstance(doc, dict)
    return doc


def test_chatter_exports_exactly_this(tmp_path: Path) -> None:
    doc = exported(CHATTER, tmp_path)
    node = {"talk": "talker", "listen": "listener"}
    assert doc == {
        "chatter": {"ros__parameters": {
            "type": "system", "parts": "talker listener",
            "modes": {
                "__DEFAULT__": {"talker": "active.__DEFAULT__", "listener": "active.__DEFAULT__"},
                "DEGRADED": {"talker": "active.DEGRADED", "listener": "active.DEGRADED"},
                # the listener assumes what only the talker gives: degrading one forces the other
                "DEGRADED_talker": {"talker": "active.DEGRADED", "listener": "active.DEGRADED"},
                "DEGRADED_listener": {"talker": "active.__DEFAULT__", "listener": "active.DEGRADED"}}}},
        **{n: {"ros__parameters": {"type": "node", "modes": {
            "__DEFAULT__": {"ros__parameters": {"reconf": {"mode": {f: "normal"}}}},
            "DEGRADED": {"ros__parameters": {"reconf": {"mode": {f: "degraded"}}}}}}} for f, n in node.items()},
    }
    text = (tmp_path / "modes.yaml").read_text(encoding="utf-8")
    assert "talker_v2" not in text            # a replacement version is not deployed
    assert "# reconf component talker (examples/chatter.arch:7:1)" in text.replace(os.sep, "/")
    assert "forces listener.listen: it assumes String @ 10 Hz" in text


def modes_of(doc: dict[str, Any]) -> tuple[str, dict[str, Any], dict[str, dict[str, frozenset[str]]]]:
    """The system's name and modes, and per node, per mode, the functionalities it degrades."""
    systems = [k for k, v in doc.items() if v["ros__parameters"]["type"] == "system"]
    assert len(systems) == 1
    nodes: dict[str, dict[str, frozenset[str]]] = {}
    for name, v in doc.items():
        p = v["ros__parameters"]
        if p["type"] != "node":
            continue
        assert next(iter(p["modes"])) == "__DEFAULT__"
        nodes[name] = {}
        for mode, body in p["modes"].items():
            assert list(body["ros__parameters"]) == ["reconf"] and list(body["ros__parameters"]["reconf"]) == ["mode"]
            params = body["ros__parameters"]["reconf"]["mode"]          # reconf.mode.<f>, nested
            assert all(v in ("normal", "degraded") for v in params.values())
            assert list(params) == list(next(iter(p["modes"].values()))["ros__parameters"]["reconf"]["mode"])
            nodes[name][mode] = frozenset(f for f, v in params.items() if v == "degraded")
        assert len(set(nodes[name].values())) == len(nodes[name])     # SMH infers a node's mode from them
    return systems[0], doc[systems[0]]["ros__parameters"], nodes


@pytest.mark.parametrize("arch", ALL, ids=lambda p: os.path.relpath(p, ROOT))
def test_every_exported_system_mode_is_a_valid_configuration(arch: str, tmp_path: Path) -> None:
    system = load([arch], Sources())
    safe = evaluate(system, Configuration.initial(system)).valid
    if not safe:
        refused = run("modes", "export", arch, "-o", str(tmp_path / "no.yaml"))
        assert refused.exit_code == 1 and "RC625" in refused.output and "RC201" in refused.output
        assert not (tmp_path / "no.yaml").exists()
    doc = exported(arch, tmp_path, *(() if safe else ("--degrade-unsafe",)))
    name, sysp, nodes = modes_of(doc)
    comps = [c.name for c in system.components if c.functionalities]
    assert sysp["parts"].split() == comps and set(nodes) == set(comps)
    assert next(iter(sysp["modes"])) == "__DEFAULT__"
    expected = {"__DEFAULT__", "DEGRADED"} | {f"DEGRADED_{c}" for c in comps if c != name}
    assert expected <= set(sysp["modes"]) or name != system.name
    base = Configuration.initial(system)
    for mode, parts in sysp["modes"].items():
        assert list(parts) == comps
        degraded = set()
        for comp, target in parts.items():
            state, _, node_mode = target.partition(".")
            assert state == "active" and node_mode in nodes[comp]
            degraded |= {(comp, f) for f in nodes[comp][node_mode]}
        config = Configuration(base.components, frozenset(degraded), base.roles)
        assert evaluate(system, config).valid, f"{mode} of {arch} is not valid"
        if mode == "__DEFAULT__" and safe:
            assert not degraded


def test_a_degradation_that_forces_part_of_a_component_gets_a_node_mode_of_its_own(tmp_path: Path) -> None:
    doc = exported(FUSION, tmp_path)
    name, sysp, nodes = modes_of(doc)
    assert name == "fusion_2"                     # systems and nodes share SMH's namespace
    assert sysp["modes"]["DEGRADED_lidar"] == {"lidar": "active.DEGRADED",
                                               "fusion": "active.DEGRADED_obstacles_landmarks",
                                               "planner": "active.DEGRADED_avoid"}
    assert nodes["fusion"]["DEGRADED_obstacles_landmarks"] == {"obstacles", "landmarks"}
    assert list(nodes["planner"]) == ["__DEFAULT__", "DEGRADED", "DEGRADED_avoid", "DEGRADED_localize"]
    assert sysp["modes"]["DEGRADED_fusion_landmarks"]["planner"] == "active.__DEFAULT__"


@pytest.mark.parametrize("arch", [CHATTER, FUSION, os.path.join(ROOT, "examples", "robot.arch"),
                                  os.path.join(ROOT, "tests", "good_inputs", "alloy_keywords.arch")],
                         ids=os.path.basename)
def test_export_then_import_keeps_the_names(arch: str, tmp_path: Path) -> None:
    exported(arch, tmp_path)
    out = tmp_path / "back.arch"
    r = run("modes", "import", str(tmp_path / "modes.yaml"), "-o", str(out))
    assert r.exit_code == 0, r.output
    assert run("check", "--engine", "python", str(out)).exit_code == 0
    original, back = load([arch], Sources()), load([str(out)], Sources())
    names = {c.name: [f.name for f in c.functionalities] for c in original.components if c.functionalities}
    assert {c.name: [f.name for f in c.functionalities] for c in back.components} == names


def test_the_smh_example_imports_as_an_architecture_check_accepts(tmp_path: Path) -> None:
    out = tmp_path / "gripping.arch"
    r = run("modes", "import", SMH_EXAMPLE, "-o", str(out), "--output-format", "json")
    assert r.exit_code == 0, r.output
    report = json.loads(r.stdout)
    codes = [(d["code"], d["message"]) for d in report["diagnostics"]]
    assert report["verdict"] == "done"
    assert sum(c == "RC623" for c, _ in codes) == 4          # each node's ports, and the topics
    assert ("RC624", "system gripping: rules are not carried over (back_to_default)") in codes
    assert ("RC624", "mode __DEFAULT__ of gripping puts arm in state inactive: an architecture's components are "
                     "active (or absent)") in codes
    assert ("RC624", "node left/gripper is the component left_gripper: a component's name is a name of the DSL "
                     "and its node's name") in codes
    checked = run("check", "--engine", "python", str(out))
    assert checked.exit_code == 0, checked.output
    system = load([str(out)], Sources())
    assert system.name == "gripping"
    assert [(c.name, [f.name for f in c.functionalities]) for c in system.components] == [
        ("arm", ["arm"]), ("base", ["base"]), ("left_gripper", ["left_gripper"])]
    text = out.read_text(encoding="utf-8")
    assert "//   CAREFUL: arm active.GENTLE, base active.CRAWL, left/gripper active.__DEFAULT__" in text
    assert "//   RUN: speed: 1.2, planner: lattice" in text and "grip.width: 0.08" in text
    assert text.count("// placeholder") == 3 + 2 * 3     # the header, messages, topics; ports, modes


BAD = {
    "not_yaml": ("a: [1, 2\nb: 3\n", "RC621", 2, 2),
    "tab": ("gripping:\n\tros__parameters: {}\n", "RC621", 2, 1),
    "a_list": ("- arm\n- base\n", "RC622", 1, 1),
    "no_part": ("arm:\n  ros__parameters:\n    speed: 1\n", "RC622", 1, 1),
    "default_not_first": ("arm:\n  ros__parameters:\n    type: node\n    modes:\n      FAST:\n"
                          "        ros__parameters: {speed: 2}\n      __DEFAULT__:\n"
                          "        ros__parameters: {speed: 1}\n", "RC622", 5, 7),
    "node_mode_without_parameters": ("arm:\n  ros__parameters:\n    type: node\n    modes:\n"
                                     "      __DEFAULT__:\n        speed: 1\n", "RC622", 6, 9),
    "unknown_state": ("s:\n  ros__parameters:\n    type: system\n    modes:\n      __DEFAULT__:\n"
                      "        arm: running.FAST\n", "RC622", 6, 14),
    "bad_type": ("arm:\n  ros__parameters:\n    type: robot\n", "RC622", 3, 11),
    "empty": ("# nothing\n", "RC622", 1, 1),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_model_files_give_the_code_and_where(case: str, tmp_path: Path) -> None:
    text, code, line, col = BAD[case]
    model, out = tmp_path / "bad.yaml", tmp_path / "out.arch"
    model.write_text(text, encoding="utf-8")
    out.write_text("// kept\n", encoding="utf-8")
    r = run("modes", "import", str(model), "-o", str(out))
    assert r.exit_code == 2, r.output
    assert f"{model}:{line}:{col}: error[{code}]" in r.output
    assert "Traceback" not in r.output
    assert out.read_text(encoding="utf-8") == "// kept\n"      # nothing half-written, nothing overwritten


def test_a_machine_report_needs_a_file_for_the_model() -> None:
    r = run("modes", "export", CHATTER, "--output-format", "json")
    assert r.exit_code == 2 and "give -o" in r.output


@pytest.mark.parametrize("arch", ALL, ids=lambda p: os.path.relpath(p, ROOT))
def test_what_a_degradation_forces_is_settles_least_set(arch: str) -> None:
    from checker.planning.plan import Goal, settle
    from checker.reality.smh.export import export
    system = load([arch], Sources())
    exp = export(system, degrade_unsafe=True)
    base = exp.modes[0].degraded
    config = Configuration.initial(system)
    for m in exp.modes[2:]:
        seed = {d for d in m.degraded - base if d not in dict(m.forced)}
        assert settle(system, Goal(config.components, config.roles, base | seed)).degraded == m.degraded


@pytest.mark.parametrize("argv, code, says", [
    (["modes", "export", os.path.join(ROOT, "tests", "no_such_file.arch")], 2, "RC007"),
    (["modes", "export", os.path.join(ROOT, "tests", "bad_inputs", "unterminated_string.arch")], 2, "RC003"),
    (["modes", "import", os.path.join(DATA, "no_such_file.yaml")], 2, "RC007"),
    (["modes", "export", CHATTER, "-o", os.path.join(ROOT, "tests", "no_such_dir", "x.yaml")], 2, "RC007"),
    (["modes", "import", SMH_EXAMPLE, "-o", os.path.join(ROOT, "tests", "no_such_dir", "x.arch")], 2, "RC007"),
], ids=["missing-arch", "broken-arch", "missing-model", "unwritable-yaml", "unwritable-arch"])
def test_failures_keep_the_exit_code_contract(argv: list[str], code: int, says: str) -> None:
    r = run(*argv)
    assert r.exit_code == code and says in r.output and "Traceback" not in r.output, r.output


def test_bad_input_in_json_is_an_error_document(tmp_path: Path) -> None:
    model = tmp_path / "bad.yaml"
    model.write_text("a: [1\n", encoding="utf-8")
    r = run("modes", "import", str(model), "-o", str(tmp_path / "x.arch"), "--output-format", "json")
    doc = json.loads(r.stdout)
    assert r.exit_code == 2 and doc["verdict"] == "error" and doc["diagnostics"][0]["code"] == "RC621"
    r = run("modes", "export", os.path.join(ROOT, "examples", "chatter_slow.arch"), "-o", str(tmp_path / "x.yaml"),
            "--output-format", "json")
    doc = json.loads(r.stdout)
    assert r.exit_code == 1 and doc["verdict"] == "unsafe"
    assert [d["code"] for d in doc["diagnostics"]] == ["RC625", "RC201"]
