"""The FTM nodes without ROS: every component `reconf ftm expand` makes, for every composition,
gets a behaviour of reconf_ros.nodes.ftm, and SEC's sealing holds against tampering."""
from __future__ import annotations

from pathlib import Path

import pytest

from checker.ftm.expand import expand
from checker.ftm.library import all_compositions
from reconf_dsl.ir import FtmDecl
from reconf_dsl.loader import load
from reconf_ros.nodes.ftm import BEHAVIOURS
from reconf_ros.nodes.generic import from_architecture

from .conftest import example


@pytest.mark.parametrize("composition", [str(c) for c in all_compositions()])
def test_every_expanded_node_has_a_behaviour(composition: str) -> None:
    system = load([example("ftm/deterministic_pbr.arch")])
    server = system.component("server")
    assert server is not None and server.ftm is not None
    comp = next(c for c in all_compositions() if str(c) == composition)
    out, infos = expand(system, {"server": FtmDecl(comp.expr(), server.ftm.hosts, server.ftm.span)})
    for name in infos[0].components:
        c = out.component(name)
        assert c is not None
        if "__" not in name or name.endswith("_app"):     # the application and its copies
            continue
        assert all(f.name in BEHAVIOURS for f in c.functionalities), (name, [f.name for f in c.functionalities])
        node = from_architecture(out, name)          # installs the behaviour
        # no model-driven publishing: every node's behaviour writes (the heartbeat its numbered beats)
        assert all(f.normal.callback is None and f.degraded.callback is None for f in node.functionalities), name
        assert all(not p.durable or p.alias == "FtmCert" for p in node.ports), name


def test_sec_refuses_a_tampered_or_foreign_message(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from reconf_ros.nodes.ftm import sec
    monkeypatch.setenv("RECONF_FTM_KEYS", str(tmp_path / "keys"))
    bundle = sec.provision(tmp_path / "keys")
    assert oct((tmp_path / "keys" / "client.sign.key").stat().st_mode & 0o777) == "0o600"
    client, server = sec.Keys("client"), sec.Keys("server")
    assert client.load() and server.load()
    sealed = client.seal("r-1", {"rid": "r-1", "body": {"op": "compute", "x": 1}}, bundle["certificates"]["server"])
    doc, cert = server.open("r-1", sealed, "client")
    assert doc == {"rid": "r-1", "body": {"op": "compute", "x": 1}} and cert is not None
    assert server.open("r-2", sealed, "client") == (None, None)            # another request's id
    ct = bytearray(sec._unb64(sealed["ct"]))
    ct[0] ^= 1
    assert server.open("r-1", {**sealed, "ct": sec._b64(bytes(ct))}, "client") == (None, None)
    assert server.open("r-1", sealed, "server") == (None, None)           # not from the party it claims
    other = sec.provision(tmp_path / "other")                              # a certificate of another CA
    forged = {**sealed, "cert": other["certificates"]["client"]}
    assert server.open("r-1", forged, "client") == (None, None)
    assert server.rejected == 4
