"""Expansion of every pattern and composition into the generic computation graph."""
from __future__ import annotations

from dataclasses import replace

import pytest

from checker.ftm.expand import expand, to_text
from checker.ftm.library import LIBRARY, all_compositions, compose
from checker.ftm.select import nodes
from checker.ftm.transition import parse_ftm
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.loader import load_text
from tests.support.ftm import client_server

ALL = [str(c) for c in all_compositions()]


def expanded(ftm: str):  # type: ignore[no-untyped-def]
    return expand(load_text(client_server(ftm)))


@pytest.mark.parametrize("ftm", ALL)
def test_expansion_is_valid_and_reparses(ftm: str) -> None:
    system, (info,) = expanded(ftm)
    assert evaluate(system, Configuration.initial(system)).valid
    again = load_text(to_text(system), "<expanded>")
    assert replace(again, files=()) == replace(system, files=())
    assert len(info.components) == nodes(info.composition)
    names = {c.name for c in system.components}
    assert "server__proxy" in names and "client" in names
    comp = info.composition
    for r in range(comp.replicas):
        layers = [m.layer for m in comp.mechanisms]
        for layer in layers:
            for node in ("protocol", "before", "after"):
                assert f"server__r{r}_{layer}_{node}" in names
        # only the innermost layer has a Proceed: the outer ones are replaced by the inner Protocol
        assert {n for n in names if n.startswith(f"server__r{r}_") and n.endswith("_proceed")} == \
            {f"server__r{r}_{layers[-1]}_proceed"}
    duplex = comp.duplex is not None
    assert ({"server__r0_cd", "server__r1_cd", "server__recovery", "server__r1_app"} <= names) == duplex
    assert ({"server__ca", "server__sec_client_before", "server__sec_client_after"} <= names) == ("SEC" in comp.names)
    # clients keep their service; the proxy serves it now
    conn = system.connector("/compute")
    assert conn is not None and [str(r) for r in conn.publishers] == ["server__proxy.reply"]


def test_nesting_replaces_the_outer_proceed() -> None:
    system, _ = expanded("PBR(TR)")
    bfr2prd = system.connector("/server/ftm/r0/dup/bfr2prd")
    prd2aft = system.connector("/server/ftm/r0/dup/prd2aft")
    assert bfr2prd is not None and prd2aft is not None
    assert [str(r) for r in bfr2prd.subscribers] == ["server__r0_tr_protocol.from_client"]
    assert [str(r) for r in prd2aft.publishers] == ["server__r0_tr_protocol.reply"]
    srv = system.connector("/server/ftm/r0/srv")
    assert srv is not None and [str(r) for r in srv.subscribers] == ["server__r0_tr_proceed.from_server"]


def test_sec_wraps_both_sides_and_the_ca_serves_every_before() -> None:
    system, _ = expanded("SEC(PBR(TR))")
    ca = system.connector("/server/ftm/ca")
    assert ca is not None
    assert sorted(r.component for r in ca.subscribers) == ["server__r0_sec_before", "server__r1_sec_before",
                                                           "server__sec_client_before"]
    pro2pxy = system.connector("/server/ftm/pro2pxy")
    assert pro2pxy is not None and [str(r) for r in pro2pxy.publishers] == ["server__sec_client_after.to_proxy"]


def test_roles_follow_table_two() -> None:
    for ftm, before, after in (("PBR", ("pass_request", "pass_request"), ("checkpoint", "update_state")),
                               ("LFR", ("forward_request", "handle_request"), ("notify", "handle_notification")),
                               ("AD", ("forward_request", "handle_request"), ("assert_result", "assert_result"))):
        system, _ = expanded(ftm)
        for r in (0, 1):
            b = system.component(f"server__r{r}_dup_before")
            a = system.component(f"server__r{r}_dup_after")
            assert b is not None and a is not None
            assert b.functionalities[0].name == before[r]
            assert a.functionalities[0].name == after[r]
    system, _ = expanded("TR")
    funcs = {c.name: c.functionalities[0].name for c in system.components}
    assert (funcs["server__r0_tr_before"], funcs["server__r0_tr_proceed"], funcs["server__r0_tr_after"]) == \
        ("save_restore_state", "compute", "compare")


def test_replicas_are_placed_on_the_declared_hosts() -> None:
    system, _ = expanded("PBR(TR)")
    hosts = {c.name: c.host for c in system.components}
    assert hosts["server"] == "master" and hosts["server__r0_tr_proceed"] == "master"
    assert hosts["server__r1_app"] == "slave" and hosts["server__r1_dup_protocol"] == "slave"
    assert hosts["server__proxy"] == "client_site"


def test_a_suspended_protocol_still_answers_the_proxy_without_the_rate() -> None:
    system, _ = expanded("PBR")
    config = Configuration.initial(system)
    down = [("server__r0_dup_protocol", "handle"), ("server__r0_dup_after", "checkpoint"),
            ("server__r1_dup_protocol", "handle"), ("server__r1_dup_after", "update_state")]
    # both protocols suspended with what feeds them: the proxy cannot promise its clients the
    # rate, so the proxy and the client must be degraded too
    ev = evaluate(system, replace(config, degraded=frozenset(down)))
    assert not ev.valid
    relay, use = ("server__proxy", "relay"), ("client", "use")
    assert not evaluate(system, replace(config, degraded=frozenset(down + [relay]))).valid
    ev = evaluate(system, replace(config, degraded=frozenset(down + [relay, use])))
    assert ev.valid
    assert not ev.connectors["/compute"] and not ev.connectors["/server/ftm/pro2pxy"]  # no rate
    assert ev.connectors["/server/ftm/pxy2pro"]            # the degraded proxy still forwards requests
    assert not ev.connectors["/server/ftm/r0/dup/pro2bfr"]  # nothing is forwarded inwards: requests queue


@pytest.mark.parametrize("text", ["TR(PBR)", "PBR(LFR)", "SEC(SEC)", "TR(SEC)", "PBR(SEC(TR))"])
def test_ill_formed_compositions_are_refused(text: str) -> None:
    comp, problems = compose(parse_ftm(text))
    assert comp is None and problems
    with pytest.raises(DiagnosticError) as e:
        expand(load_text(client_server(text)))
    assert e.value.diagnostics[0].code == "RC401"


def test_library_matches_table_one() -> None:
    assert LIBRARY["PBR"].covers == {"crash"} and LIBRARY["PBR"].needs == {"state_access"}
    assert LIBRARY["PBR"].bandwidth == "high" and LIBRARY["PBR"].cpus == 2
    assert LIBRARY["LFR"].needs == {"deterministic"} and LIBRARY["LFR"].bandwidth == "low"
    assert LIBRARY["TR"].covers == {"transient"} and LIBRARY["TR"].cpus == 1 and LIBRARY["TR"].bandwidth == "nil"
    assert LIBRARY["TR"].needs == {"deterministic", "state_access"}
    assert {"crash", "transient"} <= LIBRARY["AD"].covers and LIBRARY["AD"].cpus == 2


@pytest.mark.parametrize("ftm", ["PBR", "LFR(TR)", "SEC(PBR(TR))"])
def test_alloy_agrees_the_expansion_is_valid(ftm: str, bridge) -> None:  # type: ignore[no-untyped-def]
    from checker.alloy import alloy_verdict
    system, _ = expanded(ftm)
    verdict = alloy_verdict(system, Configuration.initial(system), bridge=bridge)
    assert verdict.valid and not verdict.unsatisfied


def test_component_without_a_service_cannot_be_protected() -> None:
    text = client_server("PBR").replace("service /compute: Reply @ 10 Hz { server.reply -> client.reply }",
                                        "")
    with pytest.raises(DiagnosticError) as e:
        expand(load_text(text))
    assert e.value.diagnostics[0].code == "RC407"
