"""`reconf fmt`: canonical, idempotent, comment-preserving; IR → fmt → parse gives the same IR."""
from __future__ import annotations

import errno
import itertools
import os
import re
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from hypothesis import given, settings
from hypothesis import strategies as st

from checker.cli.common import write_atomically
from checker.cli.inputs import expand
from checker.cli.main import main
from reconf_dsl import ir
from reconf_dsl.formatter import format_document
from reconf_dsl.lexer import MASTER
from reconf_dsl.loader import load
from reconf_dsl.parser import parse_text
from tests.examples_table import EXAMPLES, ROOT, Example
from tests.support.strategies import documents


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


# --- the command line: files, links, line endings, directories, standard input ------------------

MESSY = "system s\nmessage M=std_msgs/msg/String\n"
TIDY = "system s\n\nmessage M = std_msgs/msg/String\n"


def _write(path: Path, text: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, str):
        text = text.encode("utf-8")
    path.write_bytes(text)
    return path


def _fmt_cli(*args: str, input: bytes | None = None) -> Result:
    return CliRunner().invoke(main, ["fmt", *args], input=input)


def test_cli_fmt_writes_through_a_symbolic_link(tmp_path: Path) -> None:
    real = _write(tmp_path / "real" / "x.arch", MESSY)
    link = tmp_path / "link.arch"
    link.symlink_to(real)
    r = _fmt_cli(str(link))
    assert r.exit_code == 0, r.output
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert real.read_text() == TIDY
    assert sorted(os.listdir(tmp_path)) == ["link.arch", "real"] and os.listdir(real.parent) == ["x.arch"]


@pytest.mark.parametrize("newline", ["\r\n", "\n"])
def test_cli_fmt_keeps_line_endings(tmp_path: Path, newline: str) -> None:
    src = _write(tmp_path / "x.arch", MESSY.replace("\n", newline))
    assert _fmt_cli("--check", str(src)).exit_code == 1
    assert _fmt_cli(str(src)).exit_code == 0
    assert src.read_bytes() == TIDY.replace("\n", newline).encode()
    r = _fmt_cli("--check", str(src))
    assert r.exit_code == 0, r.output  # a formatted CRLF file (an autocrlf checkout) passes the check


def test_cli_fmt_mixed_line_endings_take_the_first_lines(tmp_path: Path) -> None:
    src = _write(tmp_path / "x.arch", TIDY.replace("\n", "\r\n", 1))
    assert _fmt_cli("--check", str(src)).exit_code == 1
    assert _fmt_cli(str(src)).exit_code == 0
    assert src.read_bytes() == TIDY.replace("\n", "\r\n").encode()


def test_cli_fmt_keeps_a_byte_order_mark(tmp_path: Path) -> None:
    src = _write(tmp_path / "x.arch", "\ufeff" + MESSY)
    assert _fmt_cli(str(src)).exit_code == 0
    assert src.read_bytes() == ("\ufeff" + TIDY).encode("utf-8")
    assert _fmt_cli("--check", str(src)).exit_code == 0


def test_cli_fmt_goes_on_after_a_file_it_cannot_parse(tmp_path: Path) -> None:
    bad1 = _write(tmp_path / "a_bad.arch", "system s\nmessage M std\n")
    good = _write(tmp_path / "b_good.arch", MESSY)
    bad2 = _write(tmp_path / "c_bad.arch", b"system s\n\xff\n")
    r = _fmt_cli("--check", str(bad1), str(good), str(bad2))
    assert r.exit_code == 2  # bad input wins over "would reformat"
    assert "would reformat" in r.stderr and "b_good.arch" in r.stderr
    r = _fmt_cli(str(bad1), str(good), str(bad2))
    assert r.exit_code == 2
    assert good.read_text() == TIDY
    assert bad1.read_text() == "system s\nmessage M std\n"
    assert re.search(r"a_bad\.arch:2:11: error\[RC001\]", r.stderr), r.stderr
    assert re.search(r"c_bad\.arch:2:1: error\[RC005\]", r.stderr), r.stderr
    assert "Traceback" not in r.output
    assert sorted(os.listdir(tmp_path)) == ["a_bad.arch", "b_good.arch", "c_bad.arch"]


def test_cli_fmt_a_directory_and_excludes(tmp_path: Path) -> None:
    files = [_write(tmp_path / name, MESSY) for name in
             ("a.arch", "sub/b.arch", "sub/deeper/c.arch", "gen/d.arch", ".hidden/e.arch", "sub/.f.arch",
              "notes.txt")]
    r = _fmt_cli("--check", str(tmp_path))
    assert r.exit_code == 1
    shown = re.findall(r"would reformat (\S+)", r.stderr)
    assert [os.path.relpath(s, tmp_path) for s in shown] == ["a.arch", "gen/d.arch", "sub/b.arch",
                                                             "sub/deeper/c.arch"]
    r = _fmt_cli(str(tmp_path), "--exclude", "gen", "--exclude", "deeper/*.arch")
    assert r.exit_code == 0, r.output
    assert [f.read_text() == TIDY for f in files] == [True, True, False, False, False, False, False]
    r = _fmt_cli("--check", str(tmp_path / "sub"), "--exclude", "*.arch")
    assert r.exit_code == 0 and "nothing to format" in r.stderr


def test_cli_fmt_a_directory_without_arch_files_is_bad_input(tmp_path: Path) -> None:
    _write(tmp_path / "notes.txt", "x")
    r = _fmt_cli(str(tmp_path))
    assert r.exit_code == 2 and "error[RC007]" in r.stderr and "no .arch file under" in r.stderr


def test_cli_fmt_standard_input() -> None:
    r = _fmt_cli("-", input=MESSY.encode())
    assert r.exit_code == 0 and r.stdout == TIDY
    r = _fmt_cli("-", input=MESSY.replace("\n", "\r\n").encode())
    assert r.exit_code == 0 and r.stdout_bytes == TIDY.replace("\n", "\r\n").encode()
    r = _fmt_cli("--check", "-", input=MESSY.encode())
    assert r.exit_code == 1 and r.stdout == "" and "would reformat <stdin>" in r.stderr
    assert _fmt_cli("--check", "-", input=TIDY.encode()).exit_code == 0
    r = _fmt_cli("-", input=b"system s s\n")
    assert r.exit_code == 2 and "error[RC001]" in r.stderr and r.stdout == ""


def test_cli_fmt_standard_input_in_a_process_of_its_own() -> None:
    r = subprocess.run([sys.executable, "-m", "checker", "fmt", "-"], input=MESSY.replace("\n", "\r\n").encode(),
                       capture_output=True, timeout=120, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout == TIDY.replace("\n", "\r\n").encode()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_cli_fmt_a_file_it_cannot_write_is_bad_input(tmp_path: Path) -> None:
    src = _write(tmp_path / "ro" / "x.arch", MESSY)
    src.parent.chmod(0o555)
    try:
        r = _fmt_cli(str(src))
    finally:
        src.parent.chmod(0o755)
    assert r.exit_code == 2 and "error[RC007]: cannot write" in r.stderr


def test_cli_fmt_a_write_that_fails_is_bad_input(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """As root can write anywhere, the failure is made to happen: a read-only file system."""
    import checker.cli.common

    def refuse(path: str) -> tuple[int, str]:
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), path)
    monkeypatch.setattr(checker.cli.common, "_create_beside", refuse)
    src = _write(tmp_path / "x.arch", MESSY)
    other = _write(tmp_path / "y.arch", "system s\nmessage M std\n")
    r = _fmt_cli(str(src), str(other))
    assert r.exit_code == 2
    assert re.search(r"x\.arch:1:1: error\[RC007\]: cannot write \S*x\.arch: Read-only file system", r.stderr)
    assert "y.arch:2:11: error[RC001]" in r.stderr


@pytest.mark.parametrize("umask", [0o022, 0o002, 0o077])
def test_written_files_respect_the_umask(tmp_path: Path, umask: int) -> None:
    old = os.umask(umask)
    try:
        write_atomically(str(tmp_path / "new.txt"), "x\n")
        r = CliRunner().invoke(main, ["graph", EXAMPLES[0].file, "-o", str(tmp_path / "g.dot")])
    finally:
        os.umask(old)
    assert r.exit_code == 0, r.output
    assert stat.S_IMODE((tmp_path / "new.txt").stat().st_mode) == 0o666 & ~umask
    assert stat.S_IMODE((tmp_path / "g.dot").stat().st_mode) == 0o666 & ~umask


def test_written_files_keep_their_mode_and_line_endings(tmp_path: Path) -> None:
    target = _write(tmp_path / "x.txt", "old\n")
    target.chmod(0o640)
    write_atomically(str(target), "a\nb\n", newline="\r\n")
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert target.read_bytes() == b"a\r\nb\r\n"


def test_the_bundled_examples_are_formatted() -> None:
    found = [os.path.relpath(p, ROOT) for p in expand([os.path.join(ROOT, "examples")])]
    assert {"examples/chatter.arch", "examples/common/messages.arch",
            "examples/ftm/client_server_pbr.arch"} <= set(found)
    r = CliRunner().invoke(main, ["fmt", "--check", os.path.join(ROOT, "examples")])
    assert r.exit_code == 0, r.stderr


def test_cli_fmt_goes_on_past_a_directory_without_arch_files(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    src = _write(tmp_path / "x.arch", MESSY)
    r = _fmt_cli(str(tmp_path / "empty"), str(src))
    assert r.exit_code == 2 and "error[RC007]: no .arch file under" in r.stderr
    assert _fmt_cli("--check", str(src)).exit_code == 0          # formatted all the same
