"""ROS 2 plan scripts (`codegen.ros2`): they compile, pass pyflakes, are deterministic, and their
`--dry-run` judges every state exactly as `checker.semantic_model.semantics.evaluate` does (differential test).
Applying a plan is tested on real ROS 2 nodes in tests/ros.

Golden scripts: `python -m tests.test_ros_script` rewrites tests/golden/ros2/ (see `golden_scripts`).
"""
from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import sys
from fractions import Fraction
from pathlib import Path
from typing import Any, Iterator, Optional

import pytest

from checker.planning import Plan, plan_replace
from checker.planning.plan import Goal, run_actions
from checker.reports.plan_document import plan_document
from checker.semantic_model.actions import Action, Degrade, Detach, Upgrade
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from codegen.ros2 import FORMAT_VERSION, model_data, render_plan_script
from reconf_dsl.ir import Predicate, Rate, System
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES, Example

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden" / "ros2"
CHATTER = ROOT / "examples" / "chatter.arch"
ROBOT = ROOT / "examples" / "robot.arch"


def chatter_plan(strategy: str) -> Plan:
    return plan_replace(load([str(CHATTER)]), "talker", "talker_v2", strategy=strategy)


def robot_plan(strategy: str) -> Plan:
    system = load([str(ROBOT)])
    old = system.component("motor_controller")
    assert old is not None
    return plan_replace(system, "motor_controller", dataclasses.replace(old, name="motor_controller_v2"),
                        strategy=strategy)


CASES = {"chatter_paper": (CHATTER, lambda: chatter_plan("paper")),
         "chatter_default": (CHATTER, lambda: chatter_plan("default")),
         "robot_paper": (ROBOT, lambda: robot_plan("paper")),
         "robot_default": (ROBOT, lambda: robot_plan("default"))}


def case_doc(name: str) -> tuple[Plan, dict[str, Any]]:
    source, make = CASES[name]
    plan = make()
    label = "replace talker" if name.startswith("chatter") else "replace motor_controller"
    doc = plan_document(label, load([str(source)]), plan,
                        {"python_engine": f"all {len(plan.states)} states valid"}, model=True)
    return plan, doc


def golden_scripts() -> Iterator[tuple[str, str]]:
    """(file name, text) of every golden script; a producer for tests/regen_golden.py."""
    for name in ("chatter_paper", "chatter_default"):
        yield name + ".py", render_plan_script(case_doc(name)[1])


def write_script(tmp_path: Path, doc: dict[str, Any], name: str = "plan.py") -> Path:
    out = tmp_path / name
    out.write_text(render_plan_script(doc), encoding="utf-8")
    return out


def run(script: Path, *args: str, env: Optional[dict[str, str]] = None,
        stdin: str = "") -> subprocess.CompletedProcess[str]:
    base = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    base["PYTHONIOENCODING"] = "utf-8"
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, input=stdin,
                          env={**base, **(env or {})}, timeout=60, cwd=str(script.parent))


STATE_LINE = re.compile(r"^\s*(\d+)\. .*\[(safe|UNSAFE)\]", re.M)


def printed_safety(stdout: str) -> dict[int, bool]:
    return {int(i): verdict == "safe" for i, verdict in STATE_LINE.findall(stdout)}


def doc_for(system: System, steps: list[Action], start: Configuration, name: str = "variant") -> dict[str, Any]:
    states = run_actions(system, start, steps)
    end = states[-1]
    plan = Plan(system, list(steps), states, name, 0, Goal(end.components, end.roles, end.degraded))
    return {"format_version": FORMAT_VERSION, "system": system.name, "fingerprint": "sha256:test", "evidence": {},
            "plan": plan.to_dict(), "model": model_data(system)}


# --- rendering --------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(CASES))
def test_script_compiles_is_clean_and_deterministic(name: str, tmp_path: Path) -> None:
    plan, doc = case_doc(name)
    text = render_plan_script(doc)
    compile(text, f"{name}.py", "exec")
    assert render_plan_script(case_doc(name)[1]) == text
    assert doc["fingerprint"] in text and "python_engine" in text
    assert "import rclpy" not in text.split("class Runtime", 1)[0], "rclpy must be imported lazily"
    path = write_script(tmp_path, doc)
    flakes = subprocess.run([sys.executable, "-m", "pyflakes", str(path)], capture_output=True, text=True)
    assert flakes.returncode == 0, flakes.stdout + flakes.stderr


def test_model_data_rates_are_exact_fractions() -> None:
    data = model_data(load([str(ROBOT)]))
    assert json.loads(json.dumps(data)) == data
    ctrl = next(c for c in data["components"] if c["name"] == "motor_controller")
    control = ctrl["functionalities"][0]
    assert control["criticality"] == 5
    assert control["normal"]["assumptions"][0] == {"message": "Obstacles", "hz": "1", "text": "Obstacles @ 1 s"}
    assert ctrl["ports"][0] == {"name": "in", "kind": "input", "message": "Obstacles",
                                "assumption": {"message": "Obstacles", "hz": "1", "text": "Obstacles @ 1 Hz"}}
    assert ctrl["run"] == "reconf-node reconf_ros.demo.robot:motor_controller" and ctrl["host"] == "base"
    assert data["environment"] == [{"name": "camera",
                                    "guarantee": {"message": "Image", "hz": "30", "text": "Image @ 30 Hz"}}]
    cmd_vel = next(c for c in data["connectors"] if c["name"] == "/cmd_vel")
    assert cmd_vel["single"] is True and cmd_vel["kind"] == "topic"
    assert {"name": "Twist", "ros_type": "geometry_msgs/msg/Twist"} in data["messages"]


def test_model_data_half_hertz() -> None:
    system = load([str(CHATTER)])
    listener = system.component("listener")
    assert listener is not None
    slow = Predicate("String", Rate(Fraction(2), "s"))
    port = dataclasses.replace(listener.ports[0], assumption=slow)
    system = dataclasses.replace(system, components=tuple(
        dataclasses.replace(c, ports=(port,)) if c.name == "listener" else c for c in system.components))
    comp = next(c for c in model_data(system)["components"] if c["name"] == "listener")
    assert comp["ports"][0]["assumption"] == {"message": "String", "hz": "1/2", "text": "String @ 2 s"}


@pytest.mark.parametrize("name", ["chatter_paper", "chatter_default"])
def test_golden(name: str) -> None:
    expected = (GOLDEN / f"{name}.py").read_text(encoding="utf-8")
    assert render_plan_script(case_doc(name)[1]) == expected, "run `python -m tests.test_ros_script` and review"


# --- dry run: differential against checker.semantic_model.semantics ---------------------------------------

@pytest.mark.parametrize("name", sorted(CASES))
def test_dry_run_agrees_with_engine(name: str, tmp_path: Path) -> None:
    plan, doc = case_doc(name)
    res = run(write_script(tmp_path, doc), "--dry-run")
    printed = printed_safety(res.stdout)
    assert printed == {i: evaluate(plan.system, s).valid for i, s in enumerate(plan.states)}
    assert res.returncode == 0, res.stdout + res.stderr
    for i, action in enumerate(plan.steps, 1):
        assert re.search(rf"^\s*{i}\. \S+ {re.escape(action.describe())} ", res.stdout, re.M)
    assert "all %d states are safe" % len(plan.states) in res.stdout


def wild_steps(system: System) -> list[Action]:
    """Degrade every functionality, upgrade them back, then detach every port: structurally
    possible, and a mix of safe and unsafe states."""
    funcs = [(c.name, f.name) for c in system.components for f in c.functionalities]
    start = Configuration.initial(system)
    steps: list[Action] = [Degrade(c, f) for c, f in funcs]
    steps += [Upgrade(c, f) for c, f in reversed(funcs)]
    steps += [Detach(conn, comp, port) for conn, comp, port in sorted(start.roles)]
    return steps


@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_dry_run_agrees_with_engine_on_unsafe_states(ex: Example, tmp_path: Path) -> None:
    system = load([ex.file])
    start = Configuration.initial(system)
    steps = wild_steps(system)
    doc = doc_for(system, steps, start)
    res = run(write_script(tmp_path, doc), "--dry-run")
    states = run_actions(system, start, steps)
    expected = {i: evaluate(system, s).valid for i, s in enumerate(states)}
    assert printed_safety(res.stdout) == expected, res.stdout
    assert res.returncode == (0 if all(expected.values()) else 1)


@pytest.mark.parametrize("name", ["chatter_paper", "robot_paper"])
def test_dropping_the_degrade_step_is_caught(name: str, tmp_path: Path) -> None:
    plan, _ = case_doc(name)
    degrade = next(a for a in plan.steps if isinstance(a, Degrade))
    # without the degrade, the matching upgrade has nothing to do: drop both
    steps = [a for a in plan.steps if a != degrade and a != Upgrade(degrade.component, degrade.functionality)]
    doc = doc_for(plan.system, steps, plan.states[0])
    res = run(write_script(tmp_path, doc), "--dry-run")
    assert res.returncode == 1
    states = run_actions(plan.system, plan.states[0], steps)
    unsafe = [i for i, s in enumerate(states) if not evaluate(plan.system, s).valid]
    assert unsafe and printed_safety(res.stdout) == {i: i not in unsafe for i in range(len(states))}
    first = unsafe[0]
    assert f"UNSAFE after step {first} ({steps[first - 1].describe()})" in res.stdout
    assert "which does not hold" in res.stdout


def test_states_that_disagree_with_the_steps_are_caught(tmp_path: Path) -> None:
    plan, doc = case_doc("chatter_default")
    doc["plan"]["steps"].pop(2)     # the attach: the recorded states no longer follow from the steps
    res = run(write_script(tmp_path, doc), "--dry-run")
    assert res.returncode == 1
    assert "records a different state" in res.stdout


def test_structurally_impossible_step_is_refused(tmp_path: Path) -> None:
    plan, doc = case_doc("chatter_paper")
    doc["plan"]["steps"].insert(0, {"action": "remove", "component": "listener"})
    res = run(write_script(tmp_path, doc), "--dry-run")
    assert res.returncode == 1
    assert "step 1 (remove listener) cannot run: listener is not isolated" in res.stdout


def test_bad_from_step_is_a_usage_error(tmp_path: Path) -> None:
    _, doc = case_doc("chatter_paper")
    res = run(write_script(tmp_path, doc), "--from-step", "9")
    assert res.returncode == 2 and "--from-step" in res.stderr


def test_no_manager_is_a_usage_error(tmp_path: Path) -> None:
    _, doc = case_doc("chatter_paper")
    res = run(write_script(tmp_path, doc), "--yes", "--manager", str(tmp_path / "none.sock"))
    assert res.returncode == 2 and "no reconf manager at" in res.stderr and "python -m reconf_ros.tools.manager" in res.stderr


# Applying a plan runs against real ROS 2 in tests/ros (test_live_plans.py, test_live_faults.py).


def regenerate() -> None:
    GOLDEN.mkdir(parents=True, exist_ok=True)
    for key, text in golden_scripts():
        (GOLDEN / key).write_text(text, encoding="utf-8")
        print("wrote", (GOLDEN / key).relative_to(ROOT))


if __name__ == "__main__":
    regenerate()


def _top_level_names(tree: Any) -> list[str]:
    import ast
    out: list[str] = []
    for stmt in tree.body:
        if isinstance(stmt, (ast.FunctionDef, ast.ClassDef)):
            out.append(stmt.name)
        elif isinstance(stmt, ast.Assign):
            out += [t.id for t in stmt.targets if isinstance(t, ast.Name)]
            out += [e.id for t in stmt.targets if isinstance(t, ast.Tuple) for e in t.elts if isinstance(e, ast.Name)]
        elif isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
            out.append(stmt.target.id)
    return out


def test_the_embedded_executor_is_its_modules_joined() -> None:
    """A plan script embeds `reconf_ros/executor/`'s modules as one text (`executor_source`): every
    embedded module's body is in it as written, in the package's order; no import among them is
    left; every name is defined once; and the joined text, run, replays a plan as the package does."""
    import ast
    import io
    import types

    from codegen.ros2 import executor_source
    from reconf_ros.executor import EMBEDDED
    from reconf_ros.executor.replay import replay
    text = executor_source()
    package = ROOT / "reconf_ros" / "executor"
    at = -1
    names: list[str] = []
    for module in EMBEDDED:
        source = (package / f"{module}.py").read_text(encoding="utf-8")
        tree = ast.parse(source)
        body = [s for s in tree.body if not isinstance(s, (ast.Import, ast.ImportFrom))][1:]   # docstring
        first = ast.get_source_segment(source, body[0])
        assert first is not None
        where = text.find(first)
        assert where > at, f"{module}'s body is not in the joined text after the modules before it"
        at = where
        names += _top_level_names(tree)
    assert sorted(n for n in set(names) if names.count(n) > 1) == [], "a name defined in two embedded modules"
    joined = ast.parse(text)
    assert not [s for s in ast.walk(joined) if isinstance(s, ast.ImportFrom) and s.level], "a relative import is left"
    embedded = types.ModuleType("embedded_executor")      # dataclasses look their module up
    sys.modules[embedded.__name__] = embedded
    try:
        exec(compile(text, "<embedded executor>", "exec"), embedded.__dict__)
    finally:
        del sys.modules[embedded.__name__]
    doc = case_doc("chatter_default")[1]
    ours, theirs = io.StringIO(), io.StringIO()
    assert replay(doc, ours) is True and embedded.replay(doc, theirs) is True
    assert ours.getvalue() == theirs.getvalue()
