"""The compiled driver (`reconf_dsl/_fastparse.pyx`) and the Python one (`reconf_dsl.lexer.Driver`)
give the same documents, comments and diagnostics (codes, messages, positions) on every file of
the corpus, the hostile inputs, fuzz mutants and edge cases of the token classes; and a rule
added to the grammar reaches the compiled driver with no change to it."""
from __future__ import annotations

import glob
import importlib.util
import os
from typing import Any

import pytest
from lark import Lark, Tree

from bench.fuzz import mutants
from reconf_dsl import lexer
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.parser import MEANINGFUL, Parser, _Callbacks, _ToIR
from tests.examples_table import ROOT
from tests.test_hostile_inputs import DEEP

COMPILED = lexer.compiled_driver_available()
pytestmark = pytest.mark.skipif(not COMPILED and importlib.util.find_spec("Cython") is None,
                                reason="Cython is not installed, so the compiled driver cannot be built here")


def test_the_compiled_driver_is_built() -> None:
    """Where Cython is installed the install builds it (setup.py): a failed build is not hidden."""
    assert COMPILED, "reconf_dsl/_fastparse is not built: run `make` (or pip install -e .)"


@pytest.fixture(scope="module")
def parsers() -> tuple[Parser, Parser]:
    fast = Parser()
    os.environ[lexer.PURE_ENV] = "1"
    try:
        pure = Parser()
    finally:
        del os.environ[lexer.PURE_ENV]
    assert lexer.driver_kind(fast._driver) == "compiled" and lexer.driver_kind(pure._driver) == "python"
    return fast, pure


def outcome(parser: Parser, text: str) -> tuple[Any, ...]:
    try:
        doc = parser.parse(text, "f.arch")
    except DiagnosticError as e:
        return ("error", [(d.code, d.message, d.span, d.notes, d.related) for d in e.diagnostics])
    comments = [(tuple(c), c.col, c.end_col, c.trailing, c.glued, c.blank_before, c.blank_after, c.next)
                for c in doc.comments]
    return ("ok", doc, repr(doc), _spans(doc), comments)


def _spans(x: Any) -> list[Any]:
    """Every span in the document, in order (spans take no part in equality)."""
    out: list[Any] = []
    stack = [x]
    while stack:
        y = stack.pop()
        span = getattr(y, "span", None)
        if span is not None:
            out.append(span)
        if isinstance(y, (list, tuple)):
            stack.extend(reversed(y))
        elif hasattr(y, "__dataclass_fields__"):
            stack.extend(getattr(y, f) for f in reversed(list(y.__dataclass_fields__)))
    return out


def same(parsers: tuple[Parser, Parser], text: str) -> None:
    fast, pure = parsers
    assert outcome(fast, text) == outcome(pure, text), text[:300]


FILES = sorted(glob.glob(os.path.join(ROOT, "examples", "**", "*.arch"), recursive=True)
               + glob.glob(os.path.join(ROOT, "tests", "bad_inputs", "*"))
               + glob.glob(os.path.join(ROOT, "tests", "good_inputs", "*")))


@pytest.mark.parametrize("path", FILES, ids=lambda p: os.path.relpath(p, ROOT))
def test_the_corpus(parsers: tuple[Parser, Parser], path: str) -> None:
    with open(path, encoding="utf-8", errors="replace") as f:
        same(parsers, f.read())


@pytest.mark.parametrize("name", sorted(DEEP))
def test_hostile_inputs(parsers: tuple[Parser, Parser], name: str) -> None:
    same(parsers, DEEP[name]())


def test_fuzz_mutants(parsers: tuple[Parser, Parser]) -> None:
    for _, data in mutants(7, 400):
        same(parsers, data.decode("utf-8", "replace"))


EDGES = [
    "", "   \n\t\v\f\r\n", "system s", "system s\n", "system", "system 1", "system s // c\n# d\n/* e\n f */",
    "system s /* unterminated", "system s /*/ x */", 'system s include "a\\"b"', 'include "a\\\nb"', 'include "a',
    "system s environment e: T @ 1.e5 Hz", "system s environment e: T @ 1e Hz", "system s environment e: T @ .5 s",
    "system s environment e: T @ -x Hz", "system s environment e: T @ +3 Hz", "system s environment e: T @ 1.2.3 Hz",
    "system s topic ~/a/b: T { }", "system s topic ~a: T { }", "system s topic /a/1: T { }", "system s topic /: T",
    "system s message M = a/b/c", "system s message M = a/", "system s message M = a//b", "system ŝ message Ω = x/ÿ",
    "system s message M = a٣", "system s environment e: T @ ٣ Hz", "system s x\u00a0y", "system s ->", "system s -",
    "system s component c { output assume: T }", "system s component run { run \"x\" host host }",
    "system s component c { ftm A(B(C)) on h, g }", "system s component c { faults crash, transient }",
    "system s component c { functionality f (a, b) criticality 2 { normal { assume T @ 1 Hz a: T } degraded { } } }",
    "system s topic /t: T single { a.o, b.o -> c.i, d.i }", "system s service /v: T { -> }", "system s }",
    "system s component c { functionality f () { normal { o: nothing } } }", "@", "system s\n\n  \u2028 x",
]


@pytest.mark.parametrize("text", EDGES)
def test_edges_of_the_token_classes(parsers: tuple[Parser, Parser], text: str) -> None:
    same(parsers, text)


def test_a_rule_added_to_the_grammar_reaches_the_compiled_driver() -> None:
    """A declaration the compiled driver has never seen: the table and the rule come from the
    grammar when the driver is made. With no method for the rule, its value is a Lark Tree of
    every token, as Lark makes it."""
    if not COMPILED:
        pytest.skip("the compiled driver is not built")
    from reconf_dsl._fastparse import FastDriver
    from reconf_dsl.span import Span

    with open(os.path.join(ROOT, "reconf_dsl", "grammar.lark"), encoding="utf-8") as f:
        grammar = f.read().replace("     | service_decl\n", "     | service_decl\n     | note_decl\n")
    grammar += 'note_decl: "note" STRING ("," STRING)*\n'
    results = []
    for compiled in (True, False):
        target = _ToIR()
        lark = Lark(grammar, parser="lalr", lexer="basic", keep_all_tokens=True, transformer=_Callbacks(target))
        driver = (FastDriver(lark, target, _Callbacks.RULES, MEANINGFUL, lexer.NAMED_WORDS, lexer.MAX_NESTING,
                             lexer._comment, lexer.TooDeep, Span) if compiled else lexer.Driver(lark))
        target.file = "f.arch"
        results.append(driver.parse('system s\nnote "a", "b"\n'))
    fast, pure = results
    assert fast == pure
    note = fast[1]
    assert isinstance(note, Tree) and note.data == "note_decl"
    assert [(t.type, str(t), t.line, t.column) for t in note.children] == [
        ("NOTE", "note", 2, 1), ("STRING", '"a"', 2, 6), ("COMMA", ",", 2, 9), ("STRING", '"b"', 2, 11)]


def test_the_python_driver_is_used_when_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(lexer.PURE_ENV, "1")
    assert lexer.driver_kind(Parser()._driver) == "python"
