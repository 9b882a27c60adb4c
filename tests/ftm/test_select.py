"""Selection by (F, A, R), the check rules RC4xx, and Python/Alloy agreement on them."""
from __future__ import annotations

import itertools
import random

import pytest

from checker.ftm.alloy_rules import alloy_ftm_verdict, alloy_profiles, ftm_rules_text
from checker.ftm.diagnose import ftm_diagnostics
from checker.ftm.library import all_compositions, compose
from checker.ftm.select import Profile, judge, profile, select
from reconf_dsl.loader import load, load_text
from tests.support.ftm import EXAMPLES, client_server


def valid_for(text: str) -> list[str]:
    system = load_text(text)
    comp = system.component("server")
    assert comp is not None
    return [str(c.composition) for c in select(profile(system, comp)) if c.valid]


def test_crash_with_state_access_and_high_bandwidth() -> None:
    got = valid_for(client_server("PBR", application="non_deterministic, state_access"))
    assert got == ["PBR", "SEC(PBR)"]


def test_deterministic_low_bandwidth_ranks_lfr_first() -> None:
    got = valid_for(client_server("LFR", application="deterministic", resources="bandwidth: low cpus: 2"))
    assert got[0] == "LFR" and "PBR" not in got and all("TR" not in g for g in got)


def test_one_cpu_leaves_only_single_replica_mechanisms() -> None:
    got = valid_for(client_server("TR", faults="transient", resources="cpus: 1"))
    assert got == ["TR", "SEC(TR)"]


def test_ranking_is_by_resource_cost() -> None:
    system = load_text(client_server("PBR", faults="crash, transient"))
    comp = system.component("server")
    assert comp is not None
    costs = [c.cost for c in select(profile(system, comp)) if c.valid]
    assert costs == sorted(costs) and len(costs) >= 3


def test_every_rejection_says_which_assumption() -> None:
    system = load_text(client_server("PBR", faults="crash, omission", application="non_deterministic",
                                     resources="bandwidth: low cpus: 1"))
    comp = system.component("server")
    assert comp is not None
    cands = select(profile(system, comp))
    assert not any(c.valid for c in cands)
    by = {str(c.composition): {r.code for r in c.reasons} for c in cands}
    assert by["PBR"] == {"RC402", "RC403", "RC404", "RC405"}
    assert "RC402" in by["AD"]  # omission is tolerated by none


def codes(text: str) -> list[tuple[str, int, int]]:
    return [(d.code, d.span.line, d.span.col) for d in ftm_diagnostics(load_text(text))]


def ftm_line(text: str) -> int:
    return next(i for i, line in enumerate(text.split("\n"), 1) if line.strip().startswith("ftm "))


def test_lfr_on_a_non_deterministic_server() -> None:
    text = client_server("LFR", application="non_deterministic, state_access")
    assert codes(text) == [("RC403", ftm_line(text), 7)]


def test_pbr_without_state_access() -> None:
    text = client_server("PBR", application="deterministic")
    assert codes(text) == [("RC403", ftm_line(text), 7)]


def test_pbr_on_low_bandwidth_points_at_pbr_inside_the_composition() -> None:
    text = client_server("SEC(PBR(TR))", faults="crash, transient, intrusion", resources="bandwidth: low")
    diags = ftm_diagnostics(load_text(text))
    assert [(d.code, d.span.line, d.span.col) for d in diags] == [("RC404", ftm_line(text), 11)]
    assert diags[0].related and "bandwidth" in diags[0].related[0].message


def test_an_uncovered_fault() -> None:
    text = client_server("PBR", faults="crash, transient", application="state_access")
    diags = ftm_diagnostics(load_text(text))
    assert [d.code for d in diags] == ["RC402"] and "transient" in diags[0].message


def test_ill_formed_and_single_host() -> None:
    assert [c for c, _, _ in codes(client_server("TR(PBR)"))] == ["RC401"]
    # one host: a warning, and its single CPU is too few for two replicas
    assert {c for c, _, _ in codes(client_server("LFR", hosts="master"))} == {"RC405", "RC406"}


def test_examples_have_no_ftm_diagnostics() -> None:
    import glob
    for path in sorted(glob.glob(f"{EXAMPLES}/*.arch")):
        assert ftm_diagnostics(load([path])) == [], path


def test_hosts_give_the_resources_when_the_component_does_not() -> None:
    system = load_text(client_server("PBR"))
    comp = system.component("server")
    assert comp is not None
    prof = profile(system, comp)
    assert prof.bandwidth == "high" and prof.cpus == 2


# --- Alloy ------------------------------------------------------------------------------------

def test_alloy_rule_checks_hold(bridge) -> None:  # type: ignore[no-untyped-def]
    outcomes = bridge.run({"ftm.als": ftm_rules_text()}, "ftm.als")
    assert len(outcomes) == 10
    assert all(o.as_expected for o in outcomes), [(o.label, o.outcome) for o in outcomes]


FAULTS = ["crash", "transient", "permanent_value", "omission", "intrusion"]
APPS = ["deterministic", "state_access"]


def profiles(n: int, seed: int) -> dict[str, Profile]:
    rnd = random.Random(seed)
    out = {}
    for i in range(n):
        faults = frozenset(f for f in FAULTS if rnd.random() < (0.1 if f == "omission" else 0.4))
        app = frozenset(a for a in APPS if rnd.random() < 0.6)
        bw = rnd.choice([None, "nil", "low", "medium", "high"])
        cpus = rnd.choice([None, 1, 2, 3])
        out[f"k{i}"] = Profile(faults, app, bw, cpus)
    return out


def test_python_and_alloy_agree_on_generated_profiles(bridge) -> None:  # type: ignore[no-untyped-def]
    profs = profiles(150, seed=7)
    comps = all_compositions()
    attached = {k: comps[i % len(comps)] for i, k in enumerate(profs)}
    verdict = alloy_profiles(profs, attached)
    for name, prof in profs.items():
        mine = {str(c) for c in comps if not judge(c, prof)}
        assert verdict.valid[name] == mine, (name, prof)
        assert (name in verdict.contradicted) == bool(judge(attached[name], prof)), name


def test_python_and_alloy_agree_on_every_small_profile(bridge) -> None:  # type: ignore[no-untyped-def]
    profs = {}
    for i, (faults, app, bw, cpus) in enumerate(itertools.product(
            [(), ("crash",), ("transient",), ("crash", "transient"), ("crash", "intrusion")],
            [(), ("deterministic",), ("state_access",), ("deterministic", "state_access")],
            ["low", "high"], [1, 2])):
        profs[f"p{i}"] = Profile(frozenset(faults), frozenset(app), bw, cpus)
    verdict = alloy_profiles(profs, {})
    for name, prof in profs.items():
        assert verdict.valid[name] == {str(c) for c in all_compositions() if not judge(c, prof)}


@pytest.mark.parametrize("ftm, application, resources, bad", [
    ("LFR", "non_deterministic, state_access", "", True),
    ("PBR", "deterministic", "", True),
    ("PBR", "state_access", "bandwidth: low", True),
    ("PBR", "state_access", "", False),
    ("SEC(PBR(TR))", "deterministic, state_access", "", True),   # omission is declared: nothing covers it
])
def test_alloy_flags_what_check_flags(ftm: str, application: str, resources: str, bad: bool,
                                      bridge) -> None:  # type: ignore[no-untyped-def]
    faults = "crash" if ftm != "SEC(PBR(TR))" else "crash, omission"
    system = load_text(client_server(ftm, faults=faults, application=application, resources=resources))
    python_bad = any(d.is_error for d in ftm_diagnostics(system))
    alloy_bad = "server" in alloy_ftm_verdict(system).contradicted
    assert python_bad == alloy_bad == bad
    assert compose(system.components[0].ftm.expr)[0] is not None  # type: ignore[union-attr]


@pytest.mark.parametrize("edit, key, code", [
    (("ftm PBR on master, slave", "ftm LFR on master, slave"), "contradicted", "RC403"),
    (("ftm PBR on master, slave", "ftm TR(PBR) on master, slave"), "misnested", "RC401"),
    (("ftm PBR on master, slave", "ftm PBR(LFR) on master, slave"), "misnested", "RC401"),
    (("ftm PBR on master, slave", "ftm PBR on master"), "hostless", "RC406"),
])
def test_check_judges_the_ftm_rules_in_alloy_too(edit: tuple[str, str], key: str, code: str, tmp_path,  # type: ignore[no-untyped-def]
                                                  bridge) -> None:
    import json

    from click.testing import CliRunner

    from checker.cli.main import main
    text = open(f"{EXAMPLES}/client_server_pbr.arch").read()
    assert edit[0] in text
    path = tmp_path / "x.arch"
    path.write_text(text.replace(*edit))
    r = CliRunner().invoke(main, ["check", "--output-format", "json", str(path)])
    assert r.exit_code == 1, r.output
    doc = json.loads(r.stdout)
    assert doc["engines"]["alloy"]["ftm_rules"][key] == ["server"]
    assert any(d["code"] == code for d in doc["diagnostics"])
    ok = CliRunner().invoke(main, ["check", f"{EXAMPLES}/client_server_pbr.arch"])
    assert ok.exit_code == 0 and "FTM rules hold, judged by Alloy too" in ok.output, ok.output


def test_check_refuses_to_answer_when_the_engines_disagree_on_the_ftm_rules(monkeypatch: pytest.MonkeyPatch,
                                                                            bridge) -> None:  # type: ignore[no-untyped-def]
    from dataclasses import replace

    from click.testing import CliRunner

    import checker.ftm.judge as judging
    from checker.cli.main import main
    real = judging.alloy_ftm_verdict
    monkeypatch.setattr(judging, "alloy_ftm_verdict", lambda s: replace(real(s), contradicted=frozenset({"server"})))
    r = CliRunner().invoke(main, ["check", f"{EXAMPLES}/client_server_pbr.arch"])
    assert r.exit_code == 2 and "RC300" in r.output and "FTM rules" in r.output, r.output
