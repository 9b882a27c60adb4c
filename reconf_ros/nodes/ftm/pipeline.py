"""The request path of paper 000 (Fig. 2–6): Proxy, Protocol, Before, Proceed, After.

Client → Proxy (adds a request id) → Protocol (duplicates, order, suspension) → Before →
Proceed (calls the application) → After → Protocol → Proxy → client. Nesting puts an inner
Protocol where a Proceed was: the documents pass through unchanged but for each layer's keys.
docs/ftm.md#running gives the documents and the reasons.
"""
from __future__ import annotations

import importlib
import itertools
import os
import signal
import time
from collections import OrderedDict, deque
from typing import Any, Callable, Optional

from reconf_dsl.ir import System

from ..api import Component
from .wire import Ports, now, pack, result_of, unpack

__all__ = ["Proxy", "Protocol", "Before", "Proceed", "After", "RESEND_AFTER", "MAX_TR_RUNS"]

RESEND_AFTER = 0.15     # s without a reply before the proxy sends a request again
RESEND_WINDOW = 20      # requests the proxy sends again at most per tick (10 ticks a second)
APP_RETRY_AFTER = 1.0   # s without the application's answer before a Proceed asks again
WINDOW = 16            # requests a protocol has inside its layer at once (TR: one)
GIVE_UP_AFTER = 2.0     # s a request may stay inside a protocol's layer, silent or overtaken by a later
                        # one, before the protocol drops it (a node that held it went away, or
                        # dropped its result while degraded): the proxy sends it again
KEEP = 10_000           # replies a proxy or protocol remembers
MAX_TR_RUNS = 5         # computations TR tries before it gives up on a majority


def _assertion() -> Callable[[dict[str, Any]], bool]:
    """The user assertion of AD: RECONF_FTM_ASSERT=MODULE:FUNCTION (the demo's by default)."""
    target = os.environ.get("RECONF_FTM_ASSERT", "reconf_ros.demo.ftm:assertion")
    module, _, name = target.partition(":")
    fn: Callable[[dict[str, Any]], bool] = getattr(importlib.import_module(module), name)
    return fn


def _seq(rid: str) -> tuple[str, int]:
    boot, _, n = rid.rpartition("-")
    return boot, int(n) if n.isdigit() else 0


def _remember(store: "OrderedDict[str, Any]", key: str, value: Any) -> None:
    store[key] = value
    while len(store) > KEEP:
        store.popitem(last=False)


class Proxy:
    """Takes the server's place for its clients: one request id per client request, forwarded
    to the current protocol, sent again while unanswered, exactly one reply per request."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        self.boot = f"{int(time.time() * 1000):x}{os.getpid() % 4096:03x}"
        self.count = itertools.count(1)
        self.rids: dict[tuple[Any, Any], str] = {}
        self.pending: "OrderedDict[str, dict[str, Any]]" = OrderedDict()
        self.answered: "OrderedDict[str, dict[str, Any]]" = OrderedDict()
        ports.output("reply").on_request(self.on_request)
        ports.input("from_pro").on_message(self.on_reply)
        comp.create_timer(10, self.resend)

    def on_request(self, msg: Any) -> None:
        doc = unpack(msg)
        if doc is None:
            return
        key = (doc.get("client"), doc.get("id"))
        rid = self.rids.get(key)
        if rid is not None and rid in self.answered:
            self.deliver(rid)          # asked again: the same reply
            return
        if rid is None:
            rid = self.rids[key] = f"{self.boot}-{next(self.count)}"
        body = {k: v for k, v in doc.items() if k not in ("client", "id")}
        self.pending[rid] = {"key": key, "req": {"rid": rid, "body": body}, "at": 0.0, "tries": 0}
        self.forward(rid)

    def forward(self, rid: str) -> None:
        entry = self.pending[rid]
        entry["at"], entry["tries"] = now(), entry["tries"] + 1
        # every request below the oldest pending one has been answered: a protocol need not
        # wait for them (one that joins late starts there)
        floor = _seq(next(iter(self.pending)))[1]
        self.p.send("to_pro", {**entry["req"], "floor": floor})

    def resend(self) -> None:
        """Send again, oldest first, what has waited too long: at most RESEND_WINDOW a tick, each
        after RESEND_AFTER doubled at every try (up to 16 times), so a slow mechanism is not
        buried under its own re-sends."""
        t, sent = now(), 0
        for rid, e in self.pending.items():
            if sent >= RESEND_WINDOW:
                break
            if t - e["at"] > RESEND_AFTER * 2 ** min(e["tries"] - 1, 4):
                sent += 1
                self.forward(rid)

    def on_reply(self, msg: Any) -> None:
        doc = unpack(msg, need="rid")
        if doc is None:
            return
        if "takeover" in doc:       # a backup's protocol took over: what is unanswered goes to it now
            for rid, e in self.pending.items():
                e["tries"] = 0
                self.forward(rid)
            return
        entry = self.pending.pop(doc["rid"], None)
        if entry is None:
            return                  # a duplicate, or already answered
        _remember(self.answered, doc["rid"], {"key": entry["key"], "reply": doc.get("reply") or {}})
        self.deliver(doc["rid"])

    def deliver(self, rid: str) -> None:
        a = self.answered[rid]
        client, ident = a["key"]
        self.p.send("reply", {**a["reply"], "client": client, "id": ident})


class Protocol:
    """One layer's protocol: answers a duplicate from its stored replies, passes requests
    inwards one at a time in the proxy's order, and queues them while suspended (degraded)."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        self.replies: "OrderedDict[str, dict[str, Any]]" = OrderedDict()
        self.mine: "OrderedDict[str, None]" = OrderedDict()   # asked through this protocol: answer them
        self.queue: deque[dict[str, Any]] = deque()
        self.held: dict[tuple[str, int], dict[str, Any]] = {}
        self.accepted: dict[str, int] = {}        # proxy boot -> highest request number taken
        self.floor: dict[str, int] = {}           # proxy boot -> every request below was answered
        # requests inside the layer, in order; TR runs one at a time (its runs save and restore the
        # state), the others pipeline: every hop is one reliable topic and one callback, in order
        self.inflight: "OrderedDict[str, float]" = OrderedDict()
        self.window = 1 if comp.name.endswith("_tr_protocol") else WINDOW
        self.dropped: set[str] = set()            # given up on: taken again if re-sent
        # a backup's checkpoints: only the latest is applied (each carries the whole state), before
        # any request goes in; `checkpointed` is the request it follows, per proxy boot
        self.checkpoint: Optional[dict[str, Any]] = None     # the latest not yet applied
        self.checkpointed: dict[str, int] = {}
        self.behind_since: Optional[float] = None
        self.heard = 0.0                          # when the layer last gave a result
        self.overtaken = 0.0                      # latest time a request went in that has its result
        ports.input("from_client").on_message(self.on_request)
        ports.input("from_after").on_message(self.on_result)
        comp.create_timer(4, self.pump)        # a give-up check; requests and results pump it
        # a suspension is complete when the layer holds no request: re-linking it before would
        # cut a request off in the middle (a TR run, say, between its save and its restore)
        comp.in_flight(ports.fn.name, lambda: len(self.inflight))
        self.notices = 0                # takeover notices still to send the proxy (on_switch)
        self.next_notice: Optional[float] = None    # when the next goes; None: not matched yet
        self.match_by = 0.0
        self.announcer: Any = None
        self.link_poll: Any = None      # pumps every 20 ms while requests wait for the layer's link
        if ports.has("from_recovery"):
            ports.input("from_recovery").on_message(self.on_switch)

    def on_request(self, msg: Any) -> None:
        req = unpack(msg, need="rid")
        if req is None:
            return
        rid = req["rid"]
        if "rejected" in req:           # an outer layer refused it: say so outwards, run nothing
            self.p.send("reply", {"rid": rid, "rejected": req["rejected"]})
            return
        _remember(self.mine, rid, None)
        if rid in self.replies:
            self.answer(rid)
            return
        boot, n = _seq(rid)
        self.floor[boot] = max(self.floor.get(boot, 0), int(req.get("floor", 0)))
        last = max(self.accepted.get(boot, 0), self.floor[boot] - 1)
        self.held = {k: v for k, v in self.held.items() if k[0] != boot or k[1] > last}
        if n <= last and rid not in self.dropped:
            return                      # taken already: its reply is on its way
        if rid in self.dropped:
            self.dropped.discard(rid)
            self.queue.append(req)
            return self.pump()
        self.held[(boot, n)] = req
        while (boot, last + 1) in self.held:     # the proxy's order, whatever the arrival order
            last += 1
            self.queue.append(self.held.pop((boot, last)))
        self.accepted[boot] = last
        self.pump()

    def on_result(self, msg: Any) -> None:
        doc = unpack(msg)
        if doc is None:
            return
        if "again" in doc:              # TR: the same request once more (it stays in flight)
            self.inward(doc["again"])
            return
        rid = str(doc.get("rid", ""))
        self.track_checkpoint(rid, doc.get("run"))
        if "run" not in doc:            # a checkpoint comes from the peer: no sign the layer works
            self.heard = now()
        self.overtaken = max(self.overtaken, self.inflight.get(rid, 0.0))
        if "rejected" in doc:           # refused inside (a bad signature): nothing to store or answer;
            if self.inflight.pop(rid, None) is not None:    # taken again if the proxy re-sends it
                self.dropped.add(rid)
            self.pump()
            return self.drained()
        result = result_of(doc, ("reply", "state"))
        if "reply" in doc and not rid.startswith("~"):      # "~": a backup's own run, not a request
            _remember(self.replies, rid, result)
            boot, n = _seq(rid)
            if n > self.accepted.get(boot, 0):
                self.accepted[boot] = n
        self.inflight.pop(rid, None)
        if rid in self.mine and "reply" in doc:
            self.p.send("reply", {"rid": rid, **result})
        self.pump()
        self.drained()

    def drained(self) -> None:
        """Say so at once when a suspended layer has emptied (`Component.in_flight`)."""
        if not self.inflight and not self.p.normal:
            self.p.comp.changed()

    def track_checkpoint(self, rid: str, run: Optional[dict[str, Any]]) -> None:
        """A backup's checkpoint (`run`, the state after request `rid`) becomes the one to apply,
        unless its state is older than the replica's; the result of the one to apply clears it."""
        boot, n = _seq(rid)
        if run is not None and n > self.checkpointed.get(boot, 0):
            self.checkpoint, self.checkpointed[boot] = run, n
        elif self.checkpoint is not None and rid == self.checkpoint["rid"]:
            self.checkpoint = None      # applied: the replica holds the latest state it was sent

    def on_switch(self, msg: Any) -> None:
        """Recovery made this protocol the server's: once the proxy's requests and this
        protocol's replies are matched, tell the proxy, three times 0.1 s apart (a volatile
        message can go before the proxy's side has matched), so it sends what is unanswered
        now instead of at its next back-off."""
        node = self.p.comp.node
        if unpack(msg) is not None and self.announcer is None and node is not None:
            self.notices, self.match_by = 3, now() + 5.0      # matched within 5 s, or never mind
            self.announcer = node.create_timer(0.02, self.announce_takeover)

    def announce_takeover(self) -> None:
        t = now()
        if self.notices == 0 or (self.next_notice is None and t > self.match_by):
            self.p.comp.node.destroy_timer(self.announcer)
            self.notices = 0
            return
        if not self.p.normal:
            return
        if self.next_notice is None:
            node = self.p.comp.node
            if node.matched("reply") == 0 or node.matched("from_client") == 0:
                return
            self.next_notice = t
        if t >= self.next_notice:
            self.p.send("reply", {"rid": "", "takeover": self.p.comp.name})
            self.notices -= 1
            self.next_notice = t + 0.1

    def pump(self) -> None:
        """Send inwards what the window allows. A request that has been inside for GIVE_UP_AFTER
        is given up only when the layer is silent since it went in, or has given the result of
        one that went in after it (each hop keeps the order): a busy layer (a slow TR, a queue
        behind a suspended protocol) still holds it, and taking another in would run two at once
        where the window says one. A request run again reaches the application under the same
        tag, which answers it from memory (Proceed), so a re-send never applies it twice."""
        t = now()
        for rid, at in list(self.inflight.items()):
            if t - at > GIVE_UP_AFTER and (self.overtaken > at or t - self.heard > GIVE_UP_AFTER):
                self.p.comp.node.get_logger().warning(f"{rid}: no result from the layer in {GIVE_UP_AFTER} s, dropped")
                self.dropped.add(rid)
                del self.inflight[rid]
                self.p.input("from_after").give_up()     # its result is no longer waited for
                self.drained()
        if not self.p.normal or not self.linked():
            return
        if self.checkpoint is not None:
            if not any(r.startswith("~") for r in self.inflight) and len(self.inflight) < self.window:
                # one at a time, sent again if given up; its floor tells an inner protocol that the
                # checkpoints it skipped are not coming (each replaces the ones before)
                self.inflight[self.checkpoint["rid"]] = t
                self.inward({**self.checkpoint, "floor": _seq(self.checkpoint["rid"])[1]})
            return                      # no request goes in before the latest state is applied
        while len(self.inflight) < self.window and self.queue and self.caught_up(self.queue[0]):
            self.next()

    def linked(self) -> bool:
        """Whether the layer's first node reads what this protocol sends inwards. A transition can
        resume a new protocol before it links its inward port (the model does not forbid it: a
        protocol queues); a request sent then would be lost, held in flight for GIVE_UP_AFTER,
        and the proxy's re-send refused as taken already, so they wait in the queue instead, and
        go in within 20 ms of the link."""
        node = self.p.comp.node
        if node.matched("to_before") > 0:
            if self.link_poll is not None:
                node.destroy_timer(self.link_poll)
                self.link_poll = None
            return True
        if self.link_poll is None and (self.queue or self.checkpoint is not None):
            self.link_poll = node.create_timer(0.02, self.pump)
        return False

    def caught_up(self, req: dict[str, Any]) -> bool:
        """Whether a backup that took over holds the state `req` follows: the proxy's floor says
        every request below it was answered, by the old primary, whose checkpoints were sent
        before its replies. One still on its way is waited for, up to GIVE_UP_AFTER; then the
        request goes in, and the log says from which state."""
        boot, n = _seq(str(req.get("rid", "")))
        have = self.checkpointed.get(boot)
        if have is None or have >= self.floor.get(boot, 0) - 1 or str(req.get("rid", "")).startswith("~"):
            self.behind_since = None
            return True
        t = now()
        self.behind_since = self.behind_since or t
        if t - self.behind_since < GIVE_UP_AFTER:
            return False
        self.p.comp.node.get_logger().error(
            f"requests {boot}-{have + 1}..{self.floor[boot] - 1} were answered, but their checkpoints never came "
            f"in {GIVE_UP_AFTER} s: serving from the state after {boot}-{have}")
        self.checkpointed[boot] = self.floor[boot] - 1
        return True

    def next(self) -> None:
        req = self.queue.popleft()
        rid = str(req.get("rid", ""))
        if rid in self.replies:                          # answered while it waited
            return self.answer(rid)
        boot, n = _seq(rid)
        if not rid.startswith("~") and n < self.floor.get(boot, 0):
            return                                       # answered by another replica meanwhile
        if boot in self.checkpointed and not rid.startswith("~"):
            self.checkpointed[boot] = max(self.checkpointed[boot], n)   # its state follows this one now
        self.inflight[rid] = now()
        self.inward(req)

    def inward(self, req: dict[str, Any]) -> None:
        if self.p.send("to_before", req):
            self.p.input("from_after").expect()

    def answer(self, rid: str) -> None:
        self.p.send("reply", {"rid": rid, **self.replies[rid]})


class Before:
    """Table II's Before: pass the request on (PBR), forward it to the follower too (LFR, AD
    leader), take it from the leader (follower), save or restore the state (TR)."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p, self.role = ports, ports.fn.name
        ports.input("from_protocol").on_message(self.on_request)
        if ports.has("from_peer"):
            ports.input("from_peer").on_message(self.on_request)

    def on_request(self, msg: Any) -> None:
        req = unpack(msg, need="rid")
        if req is None:
            return
        if "rejected" in req:
            self.p.send("to_proceed", req)
            return
        if self.role == "pass_request":
            req["want_state"] = True            # the primary's After checkpoints it
        elif self.role == "forward_request":
            self.p.send("to_peer", req)
        elif self.role == "save_restore_state":
            tr = req.get("tr") or {"run": 1}
            req["pre"] = [{"op": "get_state"}] if tr["run"] == 1 else [{"op": "set_state", "state": tr["saved"]}]
        self.p.send("to_proceed", req)


class Proceed:
    """Calls the replica's copy of the application: the layers' operations before the request's
    own (`pre`), the request, then the state when a layer wants it."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        self.pending: "OrderedDict[str, dict[str, Any]]" = OrderedDict()
        ports.input("from_before").on_message(self.on_request)
        ports.input("from_server").on_message(self.on_answer)
        comp.create_timer(4, self.retry)

    def on_request(self, msg: Any) -> None:
        req = unpack(msg, need="rid")
        if req is None:
            return
        if "rejected" in req:
            self.p.send("result", {"rid": req["rid"], "rejected": req["rejected"]})
            return
        ops = list(req.get("pre", [])) + [req["body"]] + ([{"op": "get_state"}] if req.get("want_state") else [])
        # the tag names the request and TR's run, not this call: a request that reaches the
        # application again (a re-send after a give-up, a new version of this node after a
        # transition) is answered from the application's memory instead of applied twice
        tag = f"{req['rid']}#{(req.get('tr') or {}).get('run', 1)}"
        if tag in self.pending:
            return                      # already asked: its answer is on its way
        self.pending[tag] = {"req": req, "ops": ops, "at": None}
        self.retry()

    def retry(self) -> None:
        node = self.p.comp.node
        if node is None or not self.pending or node.request_subscribers("from_server") == 0:
            return
        t = now()
        for tag, e in self.pending.items():
            if e["at"] is None or t - e["at"] > APP_RETRY_AFTER:   # the application keeps answers by tag
                if self.p.input("from_server").request(pack({"tag": tag, "ops": e["ops"]})):
                    e["at"] = t

    def on_answer(self, msg: Any) -> None:
        doc = unpack(msg)
        if doc is None or doc.get("tag") not in self.pending:
            return
        e = self.pending.pop(doc["tag"])
        req, results = e["req"], doc.get("results", [])
        npre = len(req.get("pre", []))
        out: dict[str, Any] = {"rid": req["rid"], "req": req, "pre": results[:npre], "reply": results[npre]}
        if req.get("want_state") and len(results) > npre + 1:
            out["state"] = results[npre + 1].get("state")
        self.p.send("result", out)


class After:
    """Table II's After: checkpoint to the backup (PBR), apply a checkpoint (backup), notify the
    follower (LFR), take the leader's notification (follower), compare runs (TR), assert the
    result (AD: a replica whose result fails the user assertion stops, as a self-checking
    replica does, and its crash detector's silence hands over to the other)."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p, self.role = ports, ports.fn.name
        self.assertion = _assertion() if self.role == "assert_result" else None
        ports.input("from_proceed").on_message(self.on_result)
        if ports.has("from_peer"):
            ports.input("from_peer").on_message(self.on_peer)

    def on_result(self, msg: Any) -> None:
        doc = unpack(msg, need="rid")
        if doc is None:
            return
        if "rejected" in doc:
            self.p.send("to_protocol", {"rid": doc["rid"], "rejected": doc["rejected"]})
            return
        if self.role == "compare":
            return self.compare(doc)
        result = result_of(doc)
        if self.assertion is not None and not self.assertion(doc.get("reply") or {}):
            self.p.comp.node.get_logger().error(f"{doc['rid']}: the result fails the assertion; this replica stops")
            os.kill(os.getpid(), signal.SIGKILL)    # fail-silent: the whole replica, its heartbeat too
        if self.role in ("checkpoint", "notify") and not str(doc["rid"]).startswith("~"):
            self.p.send("to_peer", result)       # sent before the reply (not yet acknowledged)
        self.p.send("to_protocol", result)

    def on_peer(self, msg: Any) -> None:
        doc = unpack(msg, need="rid")
        if doc is None:
            return
        out = result_of(doc)
        if self.role == "update_state" and "state" in doc:
            out["run"] = {"rid": f"~{doc['rid']}", "body": {"op": "set_state", "state": doc["state"]}}
        self.p.send("to_protocol", out)

    def compare(self, doc: dict[str, Any]) -> None:
        req = doc["req"]
        tr = req.get("tr") or {"run": 1, "seen": []}
        seen = list(tr.get("seen", [])) + [doc["reply"]]
        saved = doc["pre"][0].get("state") if tr["run"] == 1 and doc.get("pre") else tr.get("saved")
        agreed = [r for r in seen if seen.count(r) >= 2]
        if agreed and agreed[0] == doc["reply"]:
            self.p.send("to_protocol", result_of(doc))
            return
        if tr["run"] >= MAX_TR_RUNS:
            self.p.comp.node._fault(self.p.fn.name, RuntimeError(f"{doc['rid']}: no two of {len(seen)} runs agree"))
            return
        if len(seen) >= 2:
            self.p.comp.node.get_logger().warning(f"{doc['rid']}: no two of {len(seen)} runs agree: one more")
        again = dict(req, tr={"run": tr["run"] + 1, "saved": saved, "seen": seen})
        self.p.send("to_protocol", {"rid": doc["rid"], "again": again})
