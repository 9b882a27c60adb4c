"""The JPype bridge: errors with positions, a clear error when the jar is missing, the
SAT4J fallback, and the time limit through a worker process."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from checker.alloy import AlloyBridge, AlloyError, AlloyTimeout, metamodel_modules, run_with_timeout
from checker.alloy.metamodel import MAIN

ROOT = Path(__file__).resolve().parents[2]

LIB = "module lib/shapes\nsig Shape { side: set Shape }\n"
MAIN_OK = "open lib/shapes\nsig Square extends Shape {}\nrun { some Square and some side } for 3 expect 1\n"


def test_modules_open_each_other_in_memory(bridge: AlloyBridge) -> None:
    (o,) = bridge.run({"main.als": MAIN_OK, "lib/shapes.als": LIB}, "main.als")
    assert o.satisfiable and o.as_expected and o.outcome == "instance"
    squares = o.eval("Square")
    assert squares and all(len(t) == 1 for t in squares)
    assert all(len(t) == 2 for t in o.eval("side"))


def test_syntax_error_has_module_line_and_column(bridge: AlloyBridge) -> None:
    bad = "module lib/shapes\nsig Shape {\n  side: set Shape }}\n"
    with pytest.raises(AlloyError) as info:
        bridge.run({"main.als": MAIN_OK, "lib/shapes.als": bad}, "main.als")
    err = info.value
    assert (err.module, err.line) == ("lib/shapes.als", 3)
    assert err.column == 20
    assert str(err).startswith("lib/shapes.als:3:20: ")


def test_type_error_has_position(bridge: AlloyBridge) -> None:
    text = "sig A {}\nrun {\n  some B\n} for 2\n"
    with pytest.raises(AlloyError) as info:
        bridge.run({"m.als": text}, "m.als")
    assert (info.value.module, info.value.line, info.value.column) == ("m.als", 3, 8)


def test_unknown_solver_is_an_error(bridge: AlloyBridge) -> None:
    with pytest.raises(AlloyError, match="unknown SAT solver"):
        bridge.usable_solver("no-such-solver")


def test_native_solver_is_used_when_it_loads(bridge: AlloyBridge) -> None:
    (o,) = bridge.run({"main.als": MAIN_OK, "lib/shapes.als": LIB}, "main.als", solver="minisat")
    assert o.solver == "minisat(jni)"


def test_falls_back_to_sat4j(bridge: AlloyBridge) -> None:
    # the jar ships no CryptoMiniSat library for x86-64 Linux
    assert bridge.usable_solver("cryptominisat") == "sat4j"
    (o,) = bridge.run({"main.als": MAIN_OK, "lib/shapes.als": LIB}, "main.als", solver="cryptominisat")
    assert o.solver == "sat4j" and o.satisfiable


def test_missing_jar_gives_clear_error() -> None:
    code = (
        "from checker.alloy import AlloyBridge, AlloyUnavailable\n"
        "try:\n    AlloyBridge.get()\n"
        "except AlloyUnavailable as e:\n    print('UNAVAILABLE', e)\n"
    )
    env = {**os.environ, "RECONF_ALLOY_JAR": "/nonexistent/alloy.jar", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=60, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    line = out.stdout.strip()
    assert line.startswith("UNAVAILABLE Alloy jar not found at /nonexistent/alloy.jar")
    assert "pip install PythonAlloyClient" in line and "\n" not in line


def test_worker_returns_outcomes_with_evaluations() -> None:
    outcomes = run_with_timeout({"main.als": MAIN_OK, "lib/shapes.als": LIB}, "main.als",
                                timeout=60, evals=["Square"])
    assert outcomes[0].satisfiable and outcomes[0].eval("Square")


def test_timeout_kills_a_long_solve() -> None:
    modules = metamodel_modules(scope=10)
    start = time.monotonic()
    with pytest.raises(AlloyTimeout):
        run_with_timeout(modules, MAIN, "SafeAttach", solver="sat4j", timeout=4)
    assert time.monotonic() - start < 15



WIDE = """
import sys
from checker.alloy import AlloyBridge
n = int(sys.argv[1])
names = [f"a{i}" for i in range(n)]
text = "\\n".join(["module wide", "abstract sig A {}"]
                  + [f"one sig {', '.join(names[i:i + 8])} extends A {{}}" for i in range(0, n, 8)]
                  + ["check Many { some A } expect 0"])
if sys.argv[2:] == ["here"]:
    import checker.alloy.bridge as bridge_module
    bridge_module.on_big_stack = lambda fn, *args: fn(*args)
(o,) = AlloyBridge.get().run({"wide.als": text}, "wide.als")
print(o.outcome)
"""


def test_a_sig_of_thousands_of_atoms_translates() -> None:
    # the analyzer reads a sig's bound back one child per stack frame: in a fresh JVM, 5,000
    # children overflow the calling thread's stack, so translation runs on a thread with room
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", WIDE, "5000"], env=env, capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert out.returncode == 0 and out.stdout.strip() == "no counterexample", out.stderr[-2000:]


def test_a_solver_that_does_not_load_falls_back_and_says_so(bridge: AlloyBridge) -> None:
    """A native solver whose library does not load falls back to sat4j, and the outcome
    (what verify-meta-model reports) names sat4j."""
    key = bridge.usable_solver("glucose")
    assert bridge.solver_used("glucose") == ("glucose" if key != "sat4j" else "sat4j")
    saved = dict(bridge._usable)
    try:
        bridge._usable[str(bridge._solver("glucose").id())] = False      # as on a machine where it does not load
        assert bridge.solver_used("glucose") == "sat4j"
        (outcome,) = bridge.run({"m.als": "sig A {}\nrun { some A } for 2 expect 1\n"}, "m.als", solver="glucose")
        assert outcome.satisfiable and outcome.solver == "sat4j"
    finally:
        bridge._usable.clear()
        bridge._usable.update(saved)


TRACE = ("var sig A {}\nfact { no A and after (some A and always some A) }\n"
         "run Grow {} for 3 but 1..3 steps\nrun Never { some A and no A } for 3\n")


def test_solve_module_evaluates_every_state_of_a_trace(bridge: AlloyBridge) -> None:
    trace = bridge.solve_module(TRACE, "trace.als", ("A",))
    assert trace.satisfiable and trace.seconds >= 0
    assert trace.states[0]["A"] == set() and all(s["A"] for s in trace.states[1:])
    assert len(trace.states) >= 2
    never = bridge.solve_module(TRACE, "trace.als", ("A",), command="Never")
    assert not never.satisfiable and never.states == []
    with pytest.raises(AlloyError, match="no command"):
        bridge.solve_module(TRACE, "trace.als", command="Missing")
    with pytest.raises(AlloyError) as err:
        bridge.solve_module("sig A {\n", "broken.als")
    assert err.value.module == "broken.als" and err.value.line > 0


def test_one_backend_protocol_reached_through_one_factory() -> None:
    """Every caller holds a `Backend` from `get_backend()`; the bridge class is named only where
    it is defined and exported, and it offers every method of the protocol, alike."""
    import inspect
    import pathlib

    from checker.alloy.bridge import AlloyBridge, Backend

    root = pathlib.Path(__file__).resolve().parents[2]
    named = [str(p.relative_to(root)) for d in ("checker", "codegen", "bench") for p in (root / d).rglob("*.py")
             if "AlloyBridge" in p.read_text(encoding="utf-8")]
    assert sorted(named) == ["checker/alloy/__init__.py", "checker/alloy/bridge.py"]
    for name, member in inspect.getmembers(Backend, inspect.isfunction):
        if not name.startswith("_"):
            assert inspect.signature(getattr(AlloyBridge, name)) == inspect.signature(member), name


def test_the_factory_says_what_is_missing() -> None:
    import subprocess
    import sys
    code = ("from checker.alloy import AlloyUnavailable, get_backend\n"
            "try:\n    get_backend()\nexcept AlloyUnavailable as e:\n    print('unavailable:', e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env={**__import__("os").environ, "RECONF_ALLOY_JAR": "/nonexistent/alloy.jar"})
    assert out.stdout.startswith("unavailable: Alloy jar not found at /nonexistent/alloy.jar"), out
