"""`reconf_dsl.incremental`: a text parsed after an edit from the parse before it is the
document the whole text parses to (items, every span, every comment with what it records), and
a text that does not parse gives the diagnostics of the whole text."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Iterator

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bench.gen import generate
from reconf_dsl import ir
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.incremental import Incremental
from reconf_dsl.parser import parse_text

ROOT = Path(__file__).resolve().parents[1]
TEXTS = [p.read_text(encoding="utf-8") for p in sorted((ROOT / "examples").rglob("*.arch"))]
TEXTS.append(generate("dag", 40, 3))

# What edits insert: what a user types (names, numbers, new lines, braces, comments, keywords)
PIECES = ["x", "9", " ", "\n", "\n\n", "}", "{", "// note\n", "/* a\nb */", "@ 5 Hz", "component c9 {\n}\n",
          "message M2 = std_msgs/msg/String\n", "system other\n", '"', "topic /t: M { }\n", "->", ","]


def spans(node: Any) -> Iterator[tuple[str, Any]]:
    """Every span in `node` (an IR value), with where it was found, in order."""
    if isinstance(node, ir.Span):
        yield "", node
    elif dataclasses.is_dataclass(node) and not isinstance(node, type):
        for f in dataclasses.fields(node):
            for where, s in spans(getattr(node, f.name)):
                yield f"{type(node).__name__}.{f.name}{where}", s
    elif isinstance(node, (tuple, list)):
        for i, x in enumerate(node):
            yield from ((f"[{i}]{w}", s) for w, s in spans(x))
    span = getattr(node, "span", None)
    if isinstance(node, (str, tuple)) and isinstance(span, ir.Span):    # Located names and tuples
        yield ".span", span


def comments(doc: ir.Document) -> list[tuple[Any, ...]]:
    return [(tuple(c), c.col, c.end_col, c.trailing, c.glued, c.blank_before, c.blank_after, c.next)  # type: ignore[attr-defined]
            for c in doc.comments]


def outcome(parse: Any, text: str) -> Any:
    try:
        doc = parse(text, "f.arch")
    except DiagnosticError as e:
        return ("error", [(d.code, d.message, d.span, d.notes) for d in e.diagnostics])
    return ("ok", doc, list(spans(doc)), comments(doc), doc.system, doc.system_span)


def edit(text: str, at: float, cut: int, piece: str) -> str:
    i = int(at * len(text))
    return text[:i] + piece + text[i + cut:]


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(TEXTS), st.lists(st.tuples(st.floats(0, 1), st.integers(0, 12), st.sampled_from(PIECES)),
                                        min_size=1, max_size=6))
def test_a_reparse_is_the_whole_parse(text: str, edits: list[tuple[float, int, str]]) -> None:
    inc = Incremental(parse_text)
    assert outcome(inc.parse, text) == outcome(parse_text, text)
    for at, cut, piece in edits:
        text = edit(text, at, cut, piece)
        assert outcome(inc.parse, text) == outcome(parse_text, text), (at, cut, piece)


def test_an_edit_inside_one_component_reparses_around_it() -> None:
    """Typing on one line of a large file parses a few items, not the file."""
    text = generate("dag", 300, 1)
    calls: list[int] = []

    def counting(t: str, file: str) -> ir.Document:
        calls.append(len(t.lstrip("\n ")))
        return parse_text(t, file)

    inc = Incremental(counting)
    inc.parse(text, "f.arch")
    at = text.index("@ ", text.index("input i0: ", len(text) // 2)) + 2
    changed = text[:at] + "77" + text[at:]                      # @ 100 ms -> @ 77100 ms
    doc = inc.parse(changed, "f.arch")
    assert inc.reparsed == 1 and calls[-1] < len(text) / 50, calls
    assert outcome(lambda t, f: doc, changed) == outcome(parse_text, changed)
    lines = changed[:at] + "\n" + changed[at:]                  # a line added: parsed to the end
    doc = inc.parse(lines, "f.arch")
    assert inc.reparsed == 2 and len(text) / 3 < calls[-1] < len(text), calls
    assert outcome(lambda t, f: doc, lines) == outcome(parse_text, lines)
    far = lines[:at + 1] + "8" + lines[at + 2:] + "// the end\n"     # two edits far apart: two small regions
    doc = inc.parse(far, "f.arch")
    assert inc.reparsed == 3 and sum(calls[-2:]) < len(text) / 25, calls
    assert outcome(lambda t, f: doc, far) == outcome(parse_text, far)


def valid_edit(text: str, at: float, kind: int) -> str:
    """An edit that keeps the text parsing, mostly: a digit changed, a blank or comment line
    added at a line's start, a line's indentation changed, a trailing comment added."""
    starts = [0] + [i + 1 for i, ch in enumerate(text) if ch == "\n" and i + 1 < len(text)]
    line = starts[int(at * (len(starts) - 1))]
    if kind == 0:
        digits = [i for i, ch in enumerate(text) if ch.isdigit()]
        i = digits[int(at * (len(digits) - 1))] if digits else 0
        return text[:i] + str((int(text[i]) + 1) % 10 if text[i:i + 1].isdigit() else 1) + text[i + 1:]
    if kind == 1:
        return text[:line] + "\n" + text[line:]
    if kind == 2:
        return text[:line] + "// typed\n" + text[line:]
    if kind == 3:
        return text[:line] + "  " + text[line:]
    end = text.find("\n", line)
    end = len(text) if end < 0 else end
    return text[:end] + " // why" + text[end:]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(TEXTS), st.lists(st.lists(st.tuples(st.floats(0, 1), st.integers(0, 4)), min_size=1, max_size=3),
                                        min_size=1, max_size=6))
def test_typing_that_keeps_the_file_valid_reparses_it(text: str, steps: list[list[tuple[float, int]]]) -> None:
    """Each step is one to three edits anywhere in the file (two far apart are two changes)."""
    inc = Incremental(parse_text)
    assert outcome(inc.parse, text) == outcome(parse_text, text)
    for edits in steps:
        for at, kind in edits:
            text = valid_edit(text, at, kind)
        assert outcome(inc.parse, text) == outcome(parse_text, text), edits
