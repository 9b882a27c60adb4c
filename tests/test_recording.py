"""`reconf check --bag`: rates and types judged against the committed recordings of
tests/data/bag (tests/support/bagkit.py says what they hold), and against recordings made on the spot."""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from checker.cli.main import main
from checker.reality.rates import RateMeter, Worst
from tests.support import bagkit

DATA = bagkit.DATA
BAGS = [str(DATA / "six_seconds.db3"), str(DATA / "six_seconds.mcap")]
CONTRADICTED = str(DATA / "contradicted.arch")


def check(arch: str, bag: str, *args: str, fmt: str = "json") -> tuple[int, dict, str]:
    r = CliRunner().invoke(main, ["check", arch, "--engine", "python", "--bag", bag, "--output-format", fmt, *args])
    doc = json.loads(r.stdout) if fmt == "json" and r.stdout.strip() else {}
    return r.exit_code, doc, r.stderr


def by_who(doc: dict) -> dict[tuple[str, str], dict]:
    return {(p["who"], p["predicate"]): p for p in doc["recording"]["promises"]}


@pytest.mark.parametrize("bag", BAGS)
def test_every_rate_met(bag: str) -> None:
    code, doc, err = check(str(DATA / "bagged.arch"), bag)
    assert code == 0, err
    rec = doc["recording"]
    assert rec["judged"] == {"topics": ["/camera", "/chatter", "/cmd_vel"], "messages": 60 + 110 + 180,
                             "seconds": pytest.approx(5.966667)}
    assert rec["storage"] == ("mcap" if bag.endswith("mcap") else "sqlite3") and rec["messages"] == 380
    assert {p["verdict"] for p in rec["promises"]} == {"met"} and len(rec["promises"]) == 10
    ps = by_who(doc)
    period = ps[("listener.listen assumes", "String @ 100 ms")]
    assert period["evidence"] == ("/chatter: 10 Hz over the worst 1 s window at t = 0.0 s; "
                                  "listener.listen assumes 10 Hz (every 100 ms)")
    env = ps[("environment camera guarantees", "Image @ 30 Hz")]
    assert env["topic"] == "/camera" and env["observed"]["hz"] == pytest.approx(30.0)
    assert "named by no connector" in env["evidence"]
    assert ps[("talker.talk guarantees", "String @ 10 Hz")]["evidence"].endswith("(the topic's rate, all publishers)")


def test_the_summary_line_says_what_was_judged() -> None:
    code, _, err = check(str(DATA / "bagged.arch"), BAGS[0], fmt="text")
    assert code == 0
    assert ("recording six_seconds.db3: 3 topics, 350 messages over 6.0 s judged against 10 rates, all met" in err)
    assert re.search(r"in \d+\.\d\d s: start-up .*, reading the recording \d+\.\d\d", err), err
    _, doc, _ = check(str(DATA / "bagged.arch"), BAGS[0])
    assert 0 < doc["timing"]["reading_the_recording"] < doc["timing"]["wall"]


@pytest.mark.parametrize("bag", BAGS)
def test_a_rate_contradicted_at_a_known_time(bag: str) -> None:
    code, doc, err = check(CONTRADICTED, bag)
    assert code == 1 and doc["verdict"] == "unsafe", err
    diags = {(d["code"], d["span"]["line"], d["span"]["column"]): d for d in doc["diagnostics"]}
    topic = diags[("RC702", 50, 17)]
    assert topic["message"] == "/cmd_vel: 10 Hz over the worst 1 s window at t = 2.5 s; topic /cmd_vel promises 20 Hz"
    assert topic["span"]["file"].endswith("contradicted.arch")
    assert diags[("RC702", 11, 14)]["message"] == (
        "/cmd_vel: 10 Hz over the worst 1 s window at t = 2.5 s; controller.control guarantees 20 Hz "
        "(the topic's rate, all 2 publishers: a finding on the topic, not proved of controller alone)")
    assert diags[("RC702", 29, 21)]["message"] == (
        "/cmd_vel: 10 Hz over the worst 1 s window at t = 2.5 s; base.drive assumes 20 Hz (every 50 ms)")
    assert diags[("RC702", 54, 16)]["message"] == (
        "/status: 0.326 Hz over the worst 1 s window at t = 2.9 s (no message for 3.07 s, to the recording's end); "
        "topic /status promises 10 Hz")
    assert diags[("RC702", 43, 7)]["message"].endswith("monitor.watch guarantees 10 Hz (the topic's rate, all publishers)")
    absent = diags[("RC704", 58, 17)]
    assert absent["severity"] == "warning" and "not evidence either way" in absent["message"]
    assert sum(d["code"] == "RC702" for d in doc["diagnostics"]) == 9
    assert diags[("RC702", 25, 18)]["message"].endswith("input base.cmd_vel assumes 20 Hz (every 50 ms)")


def test_the_window_is_stated_and_changes_the_rate() -> None:
    _, doc, _ = check(CONTRADICTED, BAGS[0], "--window", "2")
    worst = by_who(doc)[("topic /cmd_vel promises", "Twist @ 20 Hz")]
    assert worst["evidence"].startswith("/cmd_vel: 15 Hz over the worst 2 s window at t = 1.5 s;")
    code, doc, _ = check(CONTRADICTED, BAGS[0], "--window", "0.2")
    assert code == 1   # a window under the gap: one interval over the silence
    assert by_who(doc)[("topic /cmd_vel promises", "Twist @ 20 Hz")]["evidence"].startswith(
        "/cmd_vel: 1.82 Hz over the worst 0.2 s window at t = 2.95 s (no message for 0.55 s)")


def test_tolerance() -> None:
    _, doc, _ = check(CONTRADICTED, BAGS[1], "--tolerance", "50")
    assert by_who(doc)[("topic /cmd_vel promises", "Twist @ 20 Hz")]["verdict"] == "met"     # 10 Hz ≥ 50% of 20
    assert by_who(doc)[("topic /status promises", "String @ 10 Hz")]["verdict"] == "contradicted"


def test_a_type_mismatch(tmp_path: Path) -> None:
    arch = tmp_path / "mistyped.arch"
    arch.write_text("system mistyped\nmessage Twist = geometry_msgs/msg/Twist\n"
                    "topic /chatter: Twist @ 10 Hz { }\n", encoding="utf-8")
    code, doc, err = check(str(arch), BAGS[1])
    assert code == 1, err
    (d,) = [d for d in doc["diagnostics"] if d["code"] == "RC703"]
    assert d["severity"] == "error" and (d["span"]["line"], d["span"]["column"]) == (3, 17)
    assert d["message"] == ("/chatter is recorded as std_msgs/msg/String; the model says "
                            "Twist = geometry_msgs/msg/Twist")
    assert by_who(doc)[("topic /chatter promises", "Twist @ 10 Hz")]["verdict"] == "contradicted"


@pytest.mark.parametrize("why", ["too short", "wrong topics"])
def test_a_recording_that_judges_nothing_is_exit_2(tmp_path: Path, why: str) -> None:
    """Every promise RC704 or RC705: a CI job must not read that as a pass."""
    topic = "/chatter" if why == "too short" else "/chatterr"
    bag = bagkit.write(tmp_path / "rec", [(topic, "std_msgs/msg/String", bagkit.stamps(10, 0.6 if why == "too short" else 3))])
    arch = tmp_path / "m.arch"
    arch.write_text("system m\nmessage String = std_msgs/msg/String\ntopic /chatter: String @ 10 Hz { }\n",
                    encoding="utf-8")
    code, doc, err = check(str(arch), str(bag))
    assert code == 2 and doc["verdict"] == "error", err
    codes = [d["code"] for d in doc["diagnostics"]]
    assert codes == (["RC705", "RC706"] if why == "too short" else ["RC704", "RC706"])
    if why == "too short":
        assert doc["diagnostics"][0]["message"] == ("the recording lasts 0.50 s, less than the 1 s window: "
                                                    "no rate is judged")
    else:
        assert doc["diagnostics"][0]["message"].startswith("/chatter is not in the recording")
    (d,) = [d for d in doc["diagnostics"] if d["code"] == "RC706"]
    assert d["severity"] == "error" and d["message"] == (
        f"the recording {bag} judged none of the model's 1 promise: the question is not answered")
    assert d["notes"][0] == f"the recording holds {topic}"
    code, _, err = check(str(arch), str(bag), fmt="text")
    assert code == 2 and "error[RC706]" in err and "Traceback" not in err


@pytest.mark.parametrize("name", ["six_seconds.db3", "six_seconds.mcap"])
def test_a_corrupt_recording_is_exit_2(tmp_path: Path, name: str) -> None:
    bad = tmp_path / name
    data = (DATA / name).read_bytes()
    bad.write_bytes(data[:len(data) // 3] + b"\x00garbage" * 64)
    code, doc, err = check(str(DATA / "bagged.arch"), str(bad))
    assert code == 2 and doc["verdict"] == "error"
    (d,) = doc["diagnostics"]
    assert d["code"] == "RC701" and d["message"].startswith(f"cannot read the recording {bad}: ")
    assert "Traceback" not in err


@pytest.mark.parametrize("what", ["missing", "not-a-bag.txt", "empty-dir"])
def test_not_a_recording_is_exit_2(tmp_path: Path, what: str) -> None:
    path = tmp_path / what
    if what == "not-a-bag.txt":
        path.write_text("hello")
    if what == "empty-dir":
        path.mkdir()
    code, _, err = check(str(DATA / "bagged.arch"), str(path), fmt="text")
    assert code == 2 and "error[RC701]: cannot read the recording" in err and "Traceback" not in err


def test_sarif_carries_the_findings() -> None:
    r = CliRunner().invoke(main, ["check", CONTRADICTED, "--engine", "python", "--bag", BAGS[0],
                                  "--output-format", "sarif"])
    assert r.exit_code == 1
    results = json.loads(r.stdout)["runs"][0]["results"]
    assert {x["ruleId"] for x in results} >= {"RC702", "RC704"}


def test_the_meter_on_its_own() -> None:
    s = 10**9
    m = RateMeter(s, 0)
    for t in (0, s // 10, 3 * s, 3 * s, 3 * s + s // 10):     # a 2.9 s silence, two messages at one instant
        m.feed(t)
    assert m.finish(5 * s) == Worst(pytest.approx(1 / 2.9), 0.1, gap=pytest.approx(2.9))
    m = RateMeter(s, 0)
    for t in (0, s // 10, 3 * s, 3 * s + s // 10):
        m.feed(t)
    assert m.finish(6 * s + s // 2) == Worst(pytest.approx(1 / 3.4), 3.1, gap=pytest.approx(3.4), to_end=True)
    m = RateMeter(s, 0, opened=True)      # the recorder's start: a window there, 2 messages over 1 s
    for t in (9 * s // 10, s):
        m.feed(t)
    assert m.finish(19 * s // 10) == Worst(2.0, 0.0)
    m = RateMeter(s, 0)                   # no stated start: the topic's first window is at its first message
    for t in (9 * s // 10, s):
        m.feed(t)
    assert m.finish(19 * s // 10) == Worst(pytest.approx(10.0), 0.9)


BEAT = ("system beat\nmessage String = std_msgs/msg/String\n"
        "topic /tick: String @ 10 Hz { }\ntopic /beat: String @ 2 s { }\n")


@pytest.mark.parametrize(("quiet", "verdict"), [(1.4, "met"), (2.5, "contradicted")])
def test_a_slow_topic_at_the_recording_s_end(tmp_path: Path, quiet: float, verdict: str) -> None:
    """/beat every 2 s, then quiet to the end: scored 1 / the silence, as the start is; contradicted
    only when the silence is longer than its period / (1 - tolerance)."""
    beats = [round(t * 1e9) for t in (0, 2, 4, 6)]
    bag = bagkit.write(tmp_path / "rec", [("/tick", "std_msgs/msg/String", bagkit.stamps(10, 6 + quiet + 0.1)),
                                          ("/beat", "std_msgs/msg/String", beats)])
    arch = tmp_path / "beat.arch"
    arch.write_text(BEAT, encoding="utf-8")
    code, doc, err = check(str(arch), str(bag))
    beat = by_who(doc)[("topic /beat promises", "String @ 2 s")]
    assert beat["verdict"] == verdict and code == (0 if verdict == "met" else 1), err
    if verdict == "met":      # 1 / 1.4 s at the end is more than the steady 1 / 2 s: the worst is a period
        assert beat["evidence"] == ("/beat: 0.5 Hz over the worst 1 s window at t = 0.0 s (no message for 2.00 s); "
                                    "topic /beat promises 0.5 Hz (every 2 s)")
    else:
        assert beat["observed"]["to_end"] and beat["observed"]["hz"] == pytest.approx(0.4)
        assert beat["evidence"] == ("/beat: 0.4 Hz over the worst 1 s window at t = 6.0 s (no message for 2.50 s, "
                                    "to the recording's end); topic /beat promises 0.5 Hz (every 2 s)")
    assert by_who(doc)[("topic /tick promises", "String @ 10 Hz")]["verdict"] == "met"


@pytest.mark.parametrize("stated", [False, True])
def test_a_topic_starting_late(tmp_path: Path, stated: bool) -> None:
    """/cam's first message 0.3 s after /tick's: without the recorder's start, its windows begin at
    its own first message (met); with it, the window at the start holds 0.3 s of silence."""
    late = [t + 300 * bagkit.MS for t in bagkit.stamps(10, 5.7)]
    bag = bagkit.write(tmp_path / "rec", [("/tick", "std_msgs/msg/String", bagkit.stamps(10, 6)),
                                          ("/cam", "std_msgs/msg/String", late)],
                       bounds=(0, 6 * 10**9) if stated else None)
    arch = tmp_path / "late.arch"
    arch.write_text("system late\nmessage String = std_msgs/msg/String\n"
                    "topic /tick: String @ 10 Hz { }\ntopic /cam: String @ 10 Hz { }\n", encoding="utf-8")
    code, doc, err = check(str(arch), str(bag))
    rec = doc["recording"]
    cam = by_who(doc)[("topic /cam promises", "String @ 10 Hz")]
    if not stated:
        assert code == 0 and rec["bounds"] == "messages" and cam["verdict"] == "met", err
        assert cam["observed"]["hz"] == pytest.approx(10.0) and rec["seconds"] == pytest.approx(5.9)
    else:
        assert code == 1 and rec["bounds"] == "recorder" and rec["seconds"] == pytest.approx(6.0)
        assert cam["evidence"] == "/cam: 8 Hz over the worst 1 s window at t = 0.0 s; topic /cam promises 10 Hz"


def test_the_committed_recordings_are_the_kit_s(tmp_path: Path) -> None:
    """tests/data/bag holds what tests/support/bagkit.py writes: a changed kit is written again."""
    out = bagkit.write(tmp_path / "again", bagkit.committed(), "mcap")
    from rosbags.rosbag2 import Reader
    with Reader(out) as a, Reader(DATA / "six_seconds.mcap") as b:
        assert [(c.topic, t) for c, t, _ in a.messages()] == [(c.topic, t) for c, t, _ in b.messages()]
    shutil.rmtree(out)


def test_the_recorder_refuses_before_it_starts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """An existing OUT, or a parent that is not a directory: exit 2 with a message, nothing written
    (tests/ros/test_live_record.py runs the recorder's live failures)."""
    from reconf_ros.tools import record
    (tmp_path / "rec").mkdir()
    assert record.main([str(tmp_path / "rec"), "--topic", "/chatter", "--duration", "1"]) == 2
    assert capsys.readouterr().err == f"{tmp_path / 'rec'} exists: a recording is written to a new directory\n"
    assert record.main([str(tmp_path / "no" / "rec"), "--topic", "/chatter", "--duration", "1"]) == 2
    assert "is not a directory: the recording cannot be written there" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"] and not any((tmp_path / "rec").iterdir())
    with pytest.raises(record.Refused, match=r"^the type no_pkg/msg/Nothing has no Python message class here "
                                             r"\(ModuleNotFoundError: No module named 'no_pkg'\): install its package$"):
        record.message_class("no_pkg/msg/Nothing")
