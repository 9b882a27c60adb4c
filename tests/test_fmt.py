"""`reconf fmt`: canonical, idempotent, comment-preserving; IR → fmt → parse gives the same IR."""
from __future__ import annotations

import os
import shutil

import pytest
from click.testing import CliRunner
from hypothesis import given, settings

from checker.cli import main
from reconf_dsl import ir
from reconf_dsl.formatter import format_document
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
  }
}  /* end */

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
