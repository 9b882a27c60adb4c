"""`reconf fmt`: canonical, idempotent, comment-preserving; IR → fmt → parse gives the same IR."""
from __future__ import annotations

import itertools
import os
import shutil

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from checker.cli import main
from reconf_dsl import ir
from reconf_dsl.formatter import format_document
from reconf_dsl.lexer import MASTER
from reconf_dsl.loader import load
from reconf_dsl.parser import parse_text
from tests.examples_table import EXAMPLES, Example
from tests.strategies import documents


@given(documents)
@settings(max_examples=300, deadline=None)
def test_ir_fmt_parse_round_trip(doc: ir.Document) -> None:
    text = format_document(doc)
    again = parse_text(text, doc.file)
    assert again == doc
    assert format_document(again) == text


@pytest.mark.parametrize("ex", EXAMPLES, ids=lambda e: e.name)
def test_examples_are_formatted_and_stable(ex: Example) -> None:
    with open(ex.file, encoding="utf-8") as f:
        text = f.read()
    doc = parse_text(text, "x.arch")
    out = format_document(doc)
    assert parse_text(out, "x.arch") == doc
    assert format_document(parse_text(out, "x.arch")) == out
    comments = [c[2] for c in doc.comments]
    for c in comments:
        assert c in out, f"comment lost: {c}"


def test_messy_layout_is_canonicalised_with_comments_kept() -> None:
    messy = """// header
system   s   # trailing
message M=std_msgs/msg/String
component c{output o:M
functionality f(o) criticality 2{normal{o:M@10 Hz} degraded{o:nothing}} /* end */ }
topic /t:M@ 10 Hz{c.o->}
"""
    out = format_document(parse_text(messy, "m.arch"))
    assert out == """// header
system s  # trailing

message M = std_msgs/msg/String

component c {
  output o: M

  functionality f (o) criticality 2 {
    normal { o: M @ 10 Hz }
    degraded { o: nothing }
  }  /* end */
}

topic /t: M @ 10 Hz {
  c.o ->
}
"""


def test_cli_fmt_check_and_write(tmp_path: "os.PathLike[str]") -> None:
    src = os.path.join(str(tmp_path), "x.arch")
    with open(src, "w") as f:
        f.write("system s\nmessage M=std_msgs/msg/String\n")
    runner = CliRunner()
    r = runner.invoke(main, ["fmt", "--check", src])
    assert r.exit_code == 1 and "would reformat" in r.stderr
    with open(src) as f:
        assert f.read() == "system s\nmessage M=std_msgs/msg/String\n"  # --check writes nothing
    r = runner.invoke(main, ["fmt", src])
    assert r.exit_code == 0
    r = runner.invoke(main, ["fmt", "--check", src])
    assert r.exit_code == 0
    with open(src) as f:
        assert f.read() == "system s\n\nmessage M = std_msgs/msg/String\n"


def test_cli_fmt_bad_input_leaves_file_alone(tmp_path: "os.PathLike[str]") -> None:
    src = os.path.join(str(tmp_path), "x.arch")
    with open(src, "w") as f:
        f.write("system s\nmessage M std\n")
    r = CliRunner().invoke(main, ["fmt", src])
    assert r.exit_code == 2 and "error[RC001]" in r.stderr
    with open(src) as f:
        assert f.read() == "system s\nmessage M std\n"
    assert os.listdir(str(tmp_path)) == ["x.arch"]  # no temporary file left behind


def test_formatting_preserves_the_system(tmp_path: "os.PathLike[str]") -> None:
    for ex in EXAMPLES:
        dst = os.path.join(str(tmp_path), ex.name)
        shutil.copytree(os.path.dirname(ex.file), dst, dirs_exist_ok=True)
        target = os.path.join(dst, os.path.basename(ex.file))
        before = load([target])
        assert CliRunner().invoke(main, ["fmt", target]).exit_code == 0
        assert load([target]) == before


# --- comments stay where they were ---------------------------------------------------------------

def _texts(doc: ir.Document) -> list[str]:
    """Every comment's text in source order; the formatter trims the ends of its lines."""
    return ["\n".join(line.rstrip() for line in c[2].split("\n")) for c in doc.comments]


def _fmt(text: str) -> str:
    return format_document(parse_text(text, "c.arch"))


HEAD = "system s\nmessage M = std_msgs/msg/String\n\n"
CANON_HEAD = "system s\n\nmessage M = std_msgs/msg/String\n\n"

# (what it shows, source after HEAD, formatted after CANON_HEAD); each keeps its comments in order
COMMENT_CASES = [
    ("above an assume in a mode", """component c {
  input i: M @ 5 Hz

  functionality f (i) {
    normal {
      // why it needs M
      assume M @ 5 Hz
    }
    degraded { }
  }
}
""", """component c {
  input i: M @ 5 Hz

  functionality f (i) {
    normal {
      // why it needs M
      assume M @ 5 Hz
    }
    degraded { }
  }
}
"""),
    ("adjacent block comments", """/* zeta */ /* alpha */
/* one
   two */ /* three */
component c { }
""", """/* zeta */  /* alpha */
/* one
   two */  /* three */
component c {
}
"""),
    ("trailing comments", """component c {  // opens
  output o: M  # the output
  functionality f (o) {
    normal { o: M @ 10 Hz }  // fast
    degraded { o: nothing }  /* silent */
  }  // f
}  // c
topic /t: M { c.o -> }  // the topic
""", """component c {  // opens
  output o: M  # the output

  functionality f (o) {
    normal { o: M @ 10 Hz }  // fast
    degraded { o: nothing }  /* silent */
  }  // f
}  // c

topic /t: M {
  c.o ->
}  // the topic
"""),
    ("above a closing brace and in an empty block", """component c {
  output o: M
  // more ports to come
}
host h {
  // nothing yet
}
""", """component c {
  output o: M
  // more ports to come
}

host h {
  // nothing yet
}
"""),
    ("a comment between port references", """topic /t: M {
  a.o /* first */ -> b.i
}
""", """topic /t: M {
  a.o ->  /* first */
  -> b.i
}
"""),
    ("two line comments that would end one line", """component c {
  output o: M
  functionality f (o, // the output
     i  // the input
  ) {
    normal { }
  }
}
""", """component c {
  output o: M

  functionality f (o, i) {  // the output
    // the input
    normal { }
  }
}
"""),
    ("empty lines around comments", """// Copyright: nobody

// Sensors
component c { }


// Actuators

component d { }
// the end
""", """// Copyright: nobody

// Sensors
component c {
}

// Actuators

component d {
}
// the end
"""),
]


@pytest.mark.parametrize("case", COMMENT_CASES, ids=lambda c: c[0])
def test_comments_stay_in_place(case: tuple[str, str, str]) -> None:
    _, source, expected = case
    out = _fmt(HEAD + source)
    assert out == CANON_HEAD + expected
    assert _fmt(out) == out
    assert _texts(parse_text(out, "c.arch")) == _texts(parse_text(HEAD + source, "c.arch"))


def test_comments_move_with_the_statements_they_are_about() -> None:
    """The canonical layout puts `run` before ports and assumptions before guarantees."""
    source = HEAD + """component c {
  // the port
  output o: M  // trailing o
  /* how it runs */ run "x"
  host h  // where
  functionality f (o) {
    normal {
      o: M @ 10 Hz  // the guarantee
      // the assumption
      assume M @ 5 Hz  // trailing assume
    }
    degraded { }
  }
}
"""
    out = _fmt(source)
    assert out == CANON_HEAD + """component c {
  /* how it runs */
  run "x"
  host h  // where
  // the port
  output o: M  // trailing o

  functionality f (o) {
    normal {
      // the assumption
      assume M @ 5 Hz  // trailing assume
      o: M @ 10 Hz  // the guarantee
    }
    degraded { }
  }
}
"""
    assert _fmt(out) == out


def test_a_comment_inside_a_one_line_statement_trails_it() -> None:
    assert _fmt("system\n// the name\ns // trailing\n") == "system s  // the name\n// trailing\n"


def _gaps(text: str) -> list[int]:
    """Where a comment can go: the start, and after each token."""
    out, pos = [0], 0
    while True:
        m = MASTER.match(text, pos)
        if m is None or m.lastgroup == "END":
            return out
        pos = m.end()
        out.append(pos)


_words = st.text(alphabet="abc xyz-_09{}", max_size=10).map(str.strip)
_COMMENTS = {"line": " // {}\n", "hash": " # {}\n", "block": " /* {} */ ", "lines": " /* {}\n   {} */ ",
             "own": "\n// {}\n", "blank before": "\n\n// {}\n", "blank after": "\n# {}\n\n",
             "block alone": "\n\n/* {} */\n\n"}
_SPACE = [" ", "\n", "\n\n", "  \n   ", "\t"]


def _respace(text: str, choices: list[int]) -> str:
    """`text` with the white space before each token or comment replaced (a line still ends a // comment)."""
    out, pos, after_line_comment = [], 0, False
    for k in itertools.count():
        m = MASTER.match(text, pos)
        if m is None or m.lastgroup == "END":
            return "".join(out) + "\n"
        space = _SPACE[choices[k % len(choices)]] if choices else " "
        out.append(("\n" if after_line_comment and "\n" not in space else space) + m.group(m.lastgroup or ""))
        after_line_comment, pos = m.lastgroup == "LINE_COMMENT", m.end()
    raise AssertionError("unreachable")


@given(documents, st.lists(st.tuples(st.integers(0, 10**6), st.sampled_from(sorted(_COMMENTS)), _words, _words),
                           max_size=12),
       st.lists(st.integers(0, len(_SPACE) - 1), max_size=30))
@settings(max_examples=300, deadline=None)
def test_formatting_with_comments_is_idempotent_and_keeps_them_in_order(
        doc: ir.Document, comments: list[tuple[int, str, str, str]], spaces: list[int]) -> None:
    text = format_document(doc)
    gaps = _gaps(text)
    inserts = sorted((gaps[at % len(gaps)], k, _COMMENTS[kind].format(a, b))
                     for k, (at, kind, a, b) in enumerate(comments))
    pieces, last = [], 0
    for at, _, comment in inserts:
        pieces += [text[last:at], comment]
        last = at
    source = _respace("".join(pieces) + text[last:], spaces)
    parsed = parse_text(source, doc.file)
    out = format_document(parsed)
    again = parse_text(out, doc.file)
    assert again == parsed == doc
    assert _texts(again) == _texts(parsed)
    assert format_document(again) == out
