"""Alloy errors in generated modules point back to the DSL declaration they came from."""
from __future__ import annotations

import pytest

from checker.alloy import AlloyBridge, AlloyError, dsl_span_for
from checker.model.config import Configuration
from codegen.alloy import mangle, render_instance, render_plan
from reconf_dsl.loader import load
from tests.examples_table import EXAMPLES

CHATTER = next(e for e in EXAMPLES if e.name == "chatter").file


def _corrupt(text: str, atom: str, after: str) -> tuple[str, int]:
    """`text` with `atom + after` replaced by `atom + " ?"` on the first line holding it
    (a syntax error right after the atom), and that line's number."""
    lines = text.splitlines(keepends=True)
    for n, line in enumerate(lines, 1):
        if atom + after in line:
            lines[n - 1] = line.replace(atom + after, atom + " ?", 1)
            return "".join(lines), n
    raise AssertionError(f"{atom}{after} not in the module")


@pytest.mark.parametrize("render", [render_instance, lambda s, c: render_plan(s, [c, c])], ids=["instance", "plan"])
def test_error_points_at_the_port_declaration(bridge: AlloyBridge, render) -> None:  # type: ignore[no-untyped-def]
    system = load([CHATTER])
    text, names = render(system, Configuration.initial(system))
    port = system.component("listener").port("sub") or next(
        p for p in system.component("listener").ports if p.kind == "input")
    atom = mangle("port", "listener", port.name)
    bad, line = _corrupt(text, atom, " -> d_")
    with pytest.raises(AlloyError) as info:
        bridge.run({"main.als": bad}, "main.als", "Verdict")
    err = info.value
    assert err.line == line
    span = dsl_span_for(err, bad, names, system)
    assert span == port.span
    assert span is not None and span.file.endswith("chatter.arch")


def test_error_on_a_component_line(bridge: AlloyBridge) -> None:
    system = load([CHATTER])
    text, names = render_instance(system, Configuration.initial(system))
    atom = mangle("component", "talker")
    bad, line = _corrupt(text, atom, " -> ")
    with pytest.raises(AlloyError) as info:
        bridge.run({"main.als": bad}, "main.als", "Verdict")
    assert info.value.line == line
    assert dsl_span_for(info.value, bad, names, system) == system.component("talker").span


def test_error_in_the_shared_semantics_has_no_span(bridge: AlloyBridge) -> None:
    system = load([CHATTER])
    text, names = render_instance(system, Configuration.initial(system))
    bad = text.replace("pred valid_j {", "pred valid_j { ?", 1)
    with pytest.raises(AlloyError) as info:
        bridge.run({"main.als": bad}, "main.als", "Verdict")
    assert dsl_span_for(info.value, bad, names, system) is None
