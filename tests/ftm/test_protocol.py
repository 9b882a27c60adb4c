"""The FTM Protocol's bookkeeping (reconf_ros/nodes/ftm/pipeline.py) driven document by document,
without ROS: what it sends inwards and outwards for the documents it is given. The live tests
(tests/ros/test_live_ftm.py, test_live_hosts.py) show the same on the wire."""
from __future__ import annotations

import json
from types import SimpleNamespace
from typing import Any, Callable, Optional

from reconf_ros.nodes.ftm.pipeline import Protocol


class _Port:
    def __init__(self) -> None:
        self.callback: Optional[Callable[[Any], None]] = None

    def on_message(self, callback: Callable[[Any], None]) -> None:
        self.callback = callback

    def expect(self) -> None:
        pass

    def give_up(self) -> None:
        pass


class _Ports:
    """What a Protocol uses of its node's ports: every document it sends is kept, by port."""

    def __init__(self, name: str) -> None:
        logger = SimpleNamespace(warning=print, error=print)
        self.readers = 1                                  # what `to_before` is matched with
        self.timers: list[Callable[[], None]] = []
        node = SimpleNamespace(get_logger=lambda: logger, matched=lambda port: self.readers,
                               create_timer=lambda period, fn: self.timers.append(fn) or fn,
                               destroy_timer=self.timers.remove)
        self.in_flight: dict[str, Callable[[], int]] = {}
        self.changes = 0
        self.comp = SimpleNamespace(name=name, node=node, create_timer=lambda hz, fn: None,
                                    in_flight=self.in_flight.__setitem__, changed=self.changed)
        self.fn = SimpleNamespace(name="handle")
        self.ports = {n: _Port() for n in ("from_client", "from_after")}
        self.sent: list[tuple[str, dict[str, Any]]] = []
        self.normal = True

    def changed(self) -> None:
        self.changes += 1

    def has(self, name: str) -> bool:
        return name in self.ports

    def input(self, name: str) -> _Port:
        return self.ports[name]

    def send(self, name: str, doc: dict[str, Any]) -> bool:
        self.sent.append((name, doc))
        return True

    def give(self, port: str, doc: dict[str, Any]) -> None:
        callback = self.ports[port].callback
        assert callback is not None
        callback(SimpleNamespace(data=json.dumps(doc)))

    def inward(self) -> list[str]:
        return [d["rid"] for n, d in self.sent if n == "to_before"]


def protocol(name: str) -> tuple[Protocol, _Ports]:
    ports = _Ports(name)
    return Protocol(ports.comp, ports, None), ports  # type: ignore[arg-type]


def checkpoint(n: int, state: int) -> dict[str, Any]:
    """What a backup's After gives its protocol for the primary's request n: the primary's reply
    and the state to apply (docs/ftm.md#running)."""
    return {"rid": f"b-{n}", "reply": {"result": n}, "state": state,
            "run": {"rid": f"~b-{n}", "body": {"op": "set_state", "state": state}}}


def test_a_backup_applies_only_the_latest_checkpoint_and_one_at_a_time() -> None:
    pro, ports = protocol("server__r1_dup_protocol")
    for n in (1, 2, 3):
        ports.give("from_after", checkpoint(n, 10 * n))
    assert ports.inward() == ["~b-1"]                     # one at a time
    ports.give("from_after", {"rid": "~b-1", "reply": {}})  # applied
    assert ports.inward() == ["~b-1", "~b-3"]             # the latest: ~b-2 is never applied
    assert ports.sent[-1][1]["floor"] == 3                # an inner protocol need not wait for ~b-2
    ports.give("from_after", {"rid": "~b-3", "reply": {}})
    assert pro.checkpoint is None


def test_an_inner_protocol_created_late_takes_a_checkpoint_whatever_its_number() -> None:
    """A TR protocol put under a running PBR backup (PBR -> PBR(TR)) first hears checkpoint ~b-134:
    its floor says the ones before it are not coming, so it goes in at once."""
    inner, ports = protocol("server__r1_tr_protocol")
    ports.give("from_client", {"rid": "~b-134", "body": {"op": "set_state", "state": 1}, "floor": 134})
    assert ports.inward() == ["~b-134"]
    without, ports2 = protocol("server__r1_tr_protocol")
    ports2.give("from_client", {"rid": "~b-134", "body": {"op": "set_state", "state": 1}})
    assert ports2.inward() == []                          # without a floor it waits for ~b-1


def test_a_backup_that_took_over_serves_no_request_before_the_state_it_follows() -> None:
    """The proxy's floor says requests below 5 were answered (by the old primary, whose
    checkpoints were sent before its replies): request 5 waits for checkpoint 4."""
    pro, ports = protocol("server__r1_dup_protocol")
    ports.give("from_after", checkpoint(2, 20))
    ports.give("from_after", {"rid": "~b-2", "reply": {}})
    ports.give("from_client", {"rid": "b-5", "body": {"op": "compute", "x": 1}, "floor": 5})
    assert ports.inward() == ["~b-2"]                     # request 5 held: checkpoint 4 is on its way
    ports.give("from_after", checkpoint(4, 40))
    assert ports.inward() == ["~b-2", "~b-4"]
    ports.give("from_after", {"rid": "~b-4", "reply": {}})
    assert ports.inward() == ["~b-2", "~b-4", "b-5"]


def test_a_suspended_protocol_says_when_its_layer_is_empty() -> None:
    """A suspension is complete only when the layer holds no request (docs/control-interface.md,
    `in_flight`): the protocol reports how many are inside, and says so at once when the last
    comes out while it is suspended, so that a plan re-links the layer only then."""
    pro, ports = protocol("server__r0_dup_protocol")
    count = ports.in_flight["handle"]
    ports.give("from_client", {"rid": "p-1", "body": {"op": "add", "x": 1}})
    assert ports.inward() == ["p-1"] and count() == 1
    ports.normal = False                                  # suspended: degraded
    ports.give("from_client", {"rid": "p-2", "body": {"op": "add", "x": 2}})
    assert ports.inward() == ["p-1"] and count() == 1     # queued, not passed on
    assert ports.changes == 0
    ports.give("from_after", {"rid": "p-1", "reply": {"result": 1}})
    assert count() == 0 and ports.changes == 1            # empty: said at once
    ports.normal = True
    ports.give("from_after", {"rid": "p-0", "reply": {"result": 0}})
    assert ports.changes == 1                             # normal again: nothing to say


def test_a_resumed_protocol_sends_nothing_inwards_before_its_layer_reads_it() -> None:
    """A transition can resume a new protocol before it links the protocol's inward port: what
    it would send then is lost. The requests wait in its queue, and go in once the layer's
    first node is matched (a 20 ms poll meanwhile), in the proxy's order."""
    pro, ports = protocol("server__r0_sec_protocol")
    ports.readers = 0
    for n in (1, 2):
        ports.give("from_client", {"rid": f"p-{n}", "body": {"op": "add", "x": n}})
    assert ports.inward() == [] and ports.in_flight["handle"]() == 0
    assert len(ports.timers) == 1                         # polling for the link, once
    ports.timers[0]()
    assert ports.inward() == []
    ports.readers = 1
    ports.timers[0]()
    assert ports.inward() == ["p-1", "p-2"] and ports.timers == []
