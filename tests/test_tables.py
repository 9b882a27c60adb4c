"""One fact, one place: the tables every other part derives from, and the copies that cannot be
derived (another language, another layer) held to them here."""
from __future__ import annotations

import re
from pathlib import Path

import click
import pytest

from checker.cli.main import main
from checker.ftm.library import LIBRARY
from checker.gate.policy import parse_policy
from checker.planning.chain import CHAIN
from checker.planning.strategies import REGISTRY, STRATEGIES
from checker.reports.formats import RENDERERS
from checker.reports.report import ReportFormat
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.resolve import KNOWN_FTMS

FTM_ALS = Path(__file__).resolve().parents[1] / "alloy_model" / "ftm.als"


def _split(text: str) -> list[str]:
    """`a + (b + c) -> d` split on its top-level `+`."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if ch == "+" and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    return parts + [cur.strip()] if cur.strip() else parts


def _atoms(side: str) -> list[str]:
    return [a.strip() for a in side.strip().strip("()").split("+")]


def _snake(atom: str) -> str:
    return re.sub(r"(?<!^)([A-Z])", r"_\1", atom.removesuffix("Layer")).lower()


def _alloy_table(fun: str) -> dict[str, set[str]]:
    """Mechanism -> values of one `fun NAME: Mech -> X { ... }` of alloy_model/ftm.als."""
    body = re.search(r"fun " + fun + r": Mech -> \w+ \{(.*?)\}", FTM_ALS.read_text(), re.S)
    assert body, f"fun {fun} not found in {FTM_ALS.name}"
    out: dict[str, set[str]] = {}
    for term in _split(" ".join(body.group(1).split())):
        lhs, rhs = term.split("->")
        for m in _atoms(lhs):
            out.setdefault(m, set()).update(_snake(v) for v in _atoms(rhs))
    return out


def test_the_alloy_ftm_facts_are_the_library_s_table_i() -> None:
    library = {
        "layer": {m.name: {m.layer} for m in LIBRARY.values()},
        "covers": {m.name: set(m.covers) for m in LIBRARY.values() if m.covers},
        "needs": {m.name: set(m.needs) for m in LIBRARY.values() if m.needs},
        "bandwidth": {m.name: {m.bandwidth} for m in LIBRARY.values()},
        "cpus": {m.name: {str(m.cpus)} for m in LIBRARY.values()},
    }
    for fun, expected in library.items():
        assert _alloy_table(fun) == expected, fun
    assert re.search(r"one sig ([\w, ]+) extends Mech", FTM_ALS.read_text()).group(1).replace(" ", "").split(",") \
        == list(LIBRARY)


def test_the_dsl_knows_the_library_s_mechanisms() -> None:
    assert KNOWN_FTMS == set(LIBRARY)


def test_every_report_format_has_its_renderer() -> None:
    assert {f.value for f in ReportFormat} == {"text", "json"} | set(RENDERERS)


def _choices(path: list[str], option: str) -> list[str]:
    cmd: click.Command = main
    for name in path:
        assert isinstance(cmd, click.Group)
        cmd = cmd.commands[name]
    (param,) = [p for p in cmd.params if p.name == option]
    assert isinstance(param.type, click.Choice)
    return list(param.type.choices)


def test_the_strategy_registry_feeds_the_cli_the_policy_and_the_chain() -> None:
    assert STRATEGIES == tuple(REGISTRY) and "default" in STRATEGIES
    for path in (["plan", "replace"], ["plan", "migrate"], ["graph-plan"], ["up"]):
        assert _choices(path, "strategy") == list(STRATEGIES), path
    assert CHAIN == (*STRATEGIES, "alloy")
    for name in STRATEGIES:
        assert parse_policy({"strategy": name}, "reconf.toml").strategy == name
    with pytest.raises(DiagnosticError) as refused:
        parse_policy({"strategy": "alloy"}, "reconf.toml")
    assert [d.code for d in refused.value.diagnostics] == ["RC505"]
