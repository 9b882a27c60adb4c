"""The history checker (reconf_ros.demo.history) on histories made by a simulated server that
applies the client's requests in a given order: a clean one is linearizable, and every anomaly
is found and named by the state its replies reveal, not by a rule about ids."""
from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Optional, Sequence

import pytest

from reconf_ros.demo.ftm import judge_log, step
from reconf_ros.demo.history import ANOMALIES, check_history, main


def history(n: int, applied: Sequence[int], answered: Optional[Sequence[int]] = None,
            extra: Sequence[tuple[int, int]] = ()) -> dict[str, Any]:
    """A client log: requests 1..n sent at t = i; the server applies `applied` in that order and
    answers each request the first time it applies it (those of `answered`, default all), at
    t = n + position; `extra`: more (request, value) replies at the end."""
    replied = set(applied if answered is None else answered)
    sent = {i: float(i) for i in range(1, n + 1)}
    replies: dict[int, list[dict[str, Any]]] = {}
    state, t = 0, float(n)
    for i in applied:
        state = step(state, i)
        t += 1
        if i in replied and i not in replies:
            replies[i] = [{"id": i, "t": t, "result": state}]
    for i, value in extra:
        t += 1
        replies.setdefault(i, []).append({"id": i, "t": t, "result": value})
    return {"sent": sent, "replies": replies}


def anomalies(log: dict[str, Any], until: float = 1e9) -> dict[str, list[int]]:
    found = check_history(log, until)
    return {k: found[k] for k in ANOMALIES if found[k]}


def test_a_clean_history_is_linearizable() -> None:
    found = check_history(history(50, range(1, 51)), until=1e9)
    assert found["linearizable"] and found["completed"] == 50
    assert anomalies(history(50, range(1, 51))) == {}


def test_a_request_never_answered_is_lost_but_not_an_anomaly_of_order() -> None:
    # request 7 applied, its reply lost on the way: the later replies show it was applied
    log = history(10, range(1, 11), answered=[i for i in range(1, 11) if i != 7])
    assert anomalies(log) == {"lost": [7]}
    assert check_history(log, until=1e9)["linearizable"]
    assert anomalies(log, until=6.5) == {}       # sent after `until`: not judged


def test_a_request_applied_twice() -> None:
    assert anomalies(history(8, [1, 2, 3, 3, 4, 5, 6, 7, 8])) == {"applied_twice": [3]}


def test_requests_applied_out_of_the_clients_order() -> None:
    assert anomalies(history(8, [1, 2, 3, 5, 4, 6, 7, 8])) == {"reordered": [4]}


def test_a_double_answer_and_a_conflicting_one() -> None:
    log = history(5, range(1, 6), extra=[(2, step(step(0, 1), 2))])
    assert anomalies(log) == {"duplicated": [2]}
    log = history(5, range(1, 6), extra=[(2, 12345)])
    assert anomalies(log) == {"duplicated": [2], "conflicting": [2]}


def test_a_wrong_value_and_a_replica_that_had_not_followed() -> None:
    log = history(6, range(1, 7))
    log["replies"][4][0]["result"] += 1         # a computation fault that got through
    assert anomalies(log)["wrong"] == [4]
    # an old primary answering request 9 from the state it had at request 5, after the backup
    # answered 6..8 (a partition healed): its reply names a state of the past
    log = history(9, range(1, 9))
    stale = step(step(step(step(step(0, 1), 2), 3), 4), 5)
    log["replies"][9] = [{"id": 9, "t": 100.0, "result": step(stale, 9)}]
    assert anomalies(log) == {"reordered": [9]} or "wrong" in anomalies(log)
    assert not check_history(log, until=1e9)["linearizable"]


def test_a_reply_to_nothing_sent() -> None:
    log = history(3, range(1, 4))
    log["replies"][40] = [{"id": 40, "t": 50.0, "result": 1}]
    assert "phantom" in anomalies(log)


def test_the_checker_agrees_with_the_clients_own_judgement_on_clean_runs() -> None:
    log = history(30, range(1, 31), answered=range(1, 29))
    judged = judge_log({"sent": log["sent"], "replies": {i: [dict(r[0], right=True)] for i, r in
                                                         log["replies"].items()}}, until=1e9)
    assert judged["lost"] == check_history(log, until=1e9)["lost"] == [29, 30]


def test_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = history(5, [1, 2, 3, 3, 4, 5])
    lines = [json.dumps({"event": "sent", "id": i, "t": t}) for i, t in log["sent"].items()]
    lines += [json.dumps({"event": "reply", **r[0]}) for r in log["replies"].values()]
    (tmp_path / "client.jsonl").write_text("\n".join(lines) + "\n")
    assert main([str(tmp_path / "client.jsonl")]) == 1
    out = capsys.readouterr().out
    assert "applied_twice: 1 request (3)" in out and "NOT linearizable" in out
    with pytest.raises(SystemExit) as usage:
        main([])
    assert usage.value.code == 2
    # --more waits on the log: no client writes to it, so the wait ends at its timeout, exit 1
    assert main([str(tmp_path / "client.jsonl"), "--more", "1", "--timeout", "0.3"]) == 1
    assert "fewer than 1 requests answered in 0.3 s" in capsys.readouterr().out


def test_more_judges_what_was_sent_before_the_last_request_answered(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """With --more, a request is lost when a later one was answered and it was not, however slow
    the replies: 3 was skipped; 5, the last sent, may still be on its way."""
    log = history(5, [1, 2, 3, 4], answered=[1, 2, 4])
    lines = [json.dumps({"event": "sent", "id": i, "t": t}) for i, t in log["sent"].items()]
    soon = time.time() + 60      # replies the wait counts as new
    lines += [json.dumps({"event": "reply", **r[0], "t": soon}) for r in log["replies"].values()]
    (tmp_path / "client.jsonl").write_text("\n".join(lines) + "\n")
    assert main([str(tmp_path / "client.jsonl"), "--more", "3", "--timeout", "5"]) == 1
    out = capsys.readouterr().out
    assert "3 more requests answered" in out and "lost: 1 request (3)" in out, out
    assert "applied_twice" not in out and "; linearizable" in out
