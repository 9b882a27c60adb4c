"""A takeover never answers from an older state than the client has seen (reconf_ros/nodes/ftm/
pipeline.py): PBR's primary checkpoints before it replies, without waiting, so a partition can
let a reply through and not its checkpoint. The proxy then sends the new primary, before the
unanswered requests, the state its last answered request left, which the backup runs unless it
holds that checkpoint or a later one. The proxy's and a protocol's logic, on fake ports."""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any, Callable

from reconf_ros.nodes.ftm.pipeline import Protocol, Proxy
from reconf_ros.nodes.ftm.wire import pack


class FakePorts:
    """What the behaviours use of `wire.Ports`: the callbacks they register, what they send."""

    def __init__(self, name: str) -> None:
        self.comp = SimpleNamespace(name=name, node=None, create_timer=lambda *a: None)
        self.callbacks: dict[str, Callable[[Any], None]] = {}
        self.sent: list[tuple[str, dict[str, Any]]] = []
        self.normal = True

    def has(self, name: str) -> bool:
        return name != "from_recovery"

    def input(self, name: str) -> Any:
        return SimpleNamespace(on_message=lambda cb: self.callbacks.__setitem__(name, cb),
                               give_up=lambda: None, expect=lambda: None)

    def output(self, name: str) -> Any:
        return SimpleNamespace(on_request=lambda cb: self.callbacks.__setitem__(name, cb))

    def send(self, name: str, doc: dict[str, Any]) -> bool:
        self.sent.append((name, doc))
        return True

    def deliver(self, port: str, doc: dict[str, Any]) -> None:
        self.callbacks[port](SimpleNamespace(data=pack(doc)))


def test_the_new_primary_runs_the_proxys_last_state_before_the_unanswered_requests() -> None:
    proxy_ports = FakePorts("server__proxy")
    proxy = Proxy(proxy_ports.comp, proxy_ports, None)      # type: ignore[arg-type]
    for i in (1, 2, 3):
        proxy_ports.deliver("reply", {"client": "c", "id": i, "op": "compute", "x": i})
    rids = [d["rid"] for port, d in proxy_ports.sent if port == "to_pro"]
    assert len(rids) == 3
    # the primary answered 1 and 2 (2 left the state 41), then was cut off; 3 is unanswered
    proxy_ports.deliver("from_pro", {"rid": rids[0], "reply": {"result": 1}, "state": 1})
    proxy_ports.deliver("from_pro", {"rid": rids[1], "reply": {"result": 41}, "state": 41})
    proxy_ports.sent.clear()
    proxy_ports.deliver("from_pro", {"rid": "", "takeover": "server__r1_dup_protocol"})
    sync, again = [d for port, d in proxy_ports.sent if port == "to_pro"]
    assert sync["rid"] == f"~sync-{rids[1]}" and sync["sync"] == rids[1]
    assert sync["body"] == {"op": "set_state", "state": 41} and again["rid"] == rids[2]

    # the backup got the checkpoint of 1, not that of 2
    backup_ports = FakePorts("server__r1_dup_protocol")
    Protocol(backup_ports.comp, backup_ports, None)          # type: ignore[arg-type]
    backup_ports.deliver("from_after", {"rid": rids[0], "reply": {"result": 1}, "state": 1,
                                        "run": {"rid": f"~{rids[0]}", "body": {"op": "set_state", "state": 1}}})
    backup_ports.deliver("from_client", sync)
    backup_ports.deliver("from_client", sync)                # the notice comes three times: run once
    backup_ports.deliver("from_client", again)
    inward = [d for port, d in backup_ports.sent if port == "to_before"]
    assert [d["rid"] for d in inward] == [f"~{rids[0]}", f"~sync-{rids[1]}", rids[2]]
    assert "sync" not in inward[1] and inward[1]["body"]["state"] == 41
    # 2 counts as taken: re-sent, it is not run again (its reply reached the client)
    backup_ports.deliver("from_client", {"rid": rids[1], "body": {"op": "compute", "x": 2}})
    assert [d["rid"] for port, d in backup_ports.sent if port == "to_before"][3:] == []


def test_a_backup_that_holds_a_later_checkpoint_does_not_go_back() -> None:
    ports = FakePorts("server__r1_dup_protocol")
    Protocol(ports.comp, ports, None)                        # type: ignore[arg-type]
    ports.deliver("from_after", {"rid": "b-5", "reply": {"result": 9}, "state": 9,
                                 "run": {"rid": "~b-5", "body": {"op": "set_state", "state": 9}}})
    ports.deliver("from_client", {"rid": "~sync-b-4", "body": {"op": "set_state", "state": 7}, "sync": "b-4",
                                  "floor": 5})
    assert [d["rid"] for port, d in ports.sent if port == "to_before"] == ["~b-5"]
