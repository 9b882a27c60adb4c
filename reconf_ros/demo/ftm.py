"""The application of paper 000's examples (examples/ftm/): a stateful, deterministic server
with get/set state, and a client that sends numbered requests at a set rate and logs every
reply with its latency (docs/ftm.md#running).

The server's state is a number; `compute x` makes it `(31·state + x) mod 1000003` and answers
it, so a reply is right only if every earlier request was applied once, in order: the client
knows the right answer to each of its requests and checks it.

    RECONF_CLIENT_HZ=50 RECONF_CLIENT_LOG=client.jsonl reconf-node reconf_ros.demo.ftm:client
"""
from __future__ import annotations

import json
import os
import time
from collections import OrderedDict
from pathlib import Path
from typing import Any, Optional, Union

from reconf_ros import Component

__all__ = ["server", "client", "step", "expected", "check", "assertion", "read_log", "wait_replies", "judge_log",
           "MODULUS"]

REPLY = "std_msgs/msg/String"
MODULUS = 1_000_003


def step(state: int, x: int) -> int:
    return (31 * state + x) % MODULUS


def check(value: int) -> int:
    """A redundant code of a result, computed with it: the assertion of AD compares the two."""
    return (value * 7919 + 17) % 65521


def assertion(reply: dict[str, Any]) -> bool:
    """The user assertion AD applies to each result (RECONF_FTM_ASSERT names another)."""
    return "result" not in reply or reply.get("check") == check(int(reply["result"]))


def expected(n: int, start: int = 0) -> list[int]:
    """The right replies to requests 1..n (request i computes x = i)."""
    out, state = [], start
    for i in range(1, n + 1):
        state = step(state, i)
        out.append(state)
    return out


def server(name: str = "server") -> Component:
    """`compute`, `get_state`, `set_state`; `flip` (a test hook) makes the next n computations
    wrong, in the result and the state, as a transient value fault would."""
    comp = Component(name)
    reply = comp.create_output("reply", REPLY, alias="Reply", service=True)
    serve = comp.create_functionality("serve", outputs=[reply], criticality=2)
    serve.set_normal_mode(outputs={reply: 10})
    serve.set_degraded_mode()
    app = {"state": 0, "flip": 0}
    answers: "OrderedDict[str, list[Any]]" = OrderedDict()

    def run(op: dict[str, Any]) -> dict[str, Any]:
        kind = op.get("op")
        if kind == "compute":
            app["state"] = step(app["state"], int(op.get("x", 0)))
            code = check(app["state"])
            if app["flip"] > 0:      # the fault strikes after the result's code was made
                app["flip"] -= 1
                app["state"] = (app["state"] + 1) % MODULUS
            return {"result": app["state"], "check": code}
        if kind == "get_state":
            return {"state": app["state"]}
        if kind == "set_state":
            app["state"] = int(op["state"])
            return {"ok": True}
        if kind == "flip":
            app["flip"] = int(op.get("n", 1))
            return {"ok": True}
        return {"error": f"unknown operation {kind!r}"}

    def on_request(msg: Any) -> None:
        try:
            doc = json.loads(msg.data)
        except ValueError:
            return
        if "tag" in doc:                          # a Proceed's call: applied once per tag (a request
                                                  # and TR's run), answered again from memory
            tag = str(doc["tag"])
            if tag not in answers:
                answers[tag] = [run(op) for op in doc.get("ops", [])]
                while len(answers) > 10_000:
                    answers.popitem(last=False)
            reply.write(reply.new(data=json.dumps({"tag": tag, "results": answers[tag]})))
        else:                                     # a client's call, without an FTM
            out = run(doc)
            reply.write(reply.new(data=json.dumps({**out, "client": doc.get("client"), "id": doc.get("id")})))

    reply.on_request(on_request)
    return comp


def client(name: str = "client") -> Component:
    """Sends `{"client", "id", "op": "compute", "x": id}` at RECONF_CLIENT_HZ (default 50) once a
    server hears it, up to RECONF_CLIENT_COUNT requests (0: no end); logs each reply as a JSON line
    to RECONF_CLIENT_LOG (default client.jsonl): id, result, right or wrong, latency."""
    comp = Component(name)
    reply = comp.create_input("reply", REPLY, 10, alias="Reply", service=True)
    use = comp.create_functionality("use", inputs=[reply])
    use.set_normal_mode()
    use.set_degraded_mode()
    hz = float(os.environ.get("RECONF_CLIENT_HZ", "50"))
    limit = int(os.environ.get("RECONF_CLIENT_COUNT", "0"))
    log_path = os.environ.get("RECONF_CLIENT_LOG", "client.jsonl")
    state: dict[str, Any] = {"next": 1, "sent": {}, "right": [0], "log": None}

    def log(doc: dict[str, Any]) -> None:
        if state["log"] is None:
            state["log"] = open(log_path, "a", buffering=1)
        state["log"].write(json.dumps(doc) + "\n")

    def send() -> None:
        node = comp.node
        n = state["next"]
        if node is None or (limit and n > limit) or node.request_subscribers("reply") == 0:
            return
        if reply.request(json.dumps({"client": comp.name, "id": n, "op": "compute", "x": n})):
            state["sent"][n] = time.time()
            log({"event": "sent", "id": n, "t": state["sent"][n]})
            state["next"] = n + 1

    def right(n: int) -> Optional[int]:
        answers = state["right"]
        while len(answers) <= n:
            answers.append(step(answers[-1], len(answers)))
        return answers[n]

    def on_reply(msg: Any) -> None:
        try:
            doc = json.loads(msg.data)
        except ValueError:
            return
        if doc.get("client") != comp.name or doc.get("id") not in state["sent"]:
            return
        n = int(doc["id"])
        t = time.time()
        log({"event": "reply", "id": n, "t": t, "result": doc.get("result"), "right": doc.get("result") == right(n),
             "latency_s": round(t - state["sent"][n], 6)})

    reply.on_message(on_reply)
    comp.create_timer(hz, send)
    return comp


def read_log(path: Union[str, Path]) -> dict[str, Any]:
    """A client's log: `sent` id → time, `replies` id → every reply it got (in order)."""
    sent: dict[int, float] = {}
    replies: dict[int, list[dict[str, Any]]] = {}
    try:
        with open(path) as fh:
            for line in fh:
                try:
                    doc = json.loads(line)
                except ValueError:
                    continue        # a line being written
                if doc.get("event") == "sent":
                    sent[doc["id"]] = doc["t"]
                elif doc.get("event") == "reply":
                    replies.setdefault(doc["id"], []).append(doc)
    except FileNotFoundError:
        pass
    return {"sent": sent, "replies": replies}


def wait_replies(path: Union[str, Path], n: int, timeout: float, after: float = 0.0) -> bool:
    """Until the client's log has `n` requests first answered after time `after` (False at `timeout` s)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if sum(1 for r in read_log(path)["replies"].values() if r[0]["t"] > after) >= n:
            return True
        time.sleep(0.1)
    return False


def judge_log(log: dict[str, Any], until: float) -> dict[str, list[int]]:
    """Requests sent before `until` with no reply (lost), with more than one (duplicated), with a
    wrong one (wrong)."""
    sent, replies = log["sent"], log["replies"]
    return {"lost": sorted(i for i, t in sent.items() if t < until and i not in replies),
            "duplicated": sorted(i for i, r in replies.items() if len(r) > 1),
            "wrong": sorted(i for i, r in replies.items() if not all(x["right"] for x in r))}
