"""One fact, one place: the tables every other part derives from, and the copies that cannot be
derived (another language, another layer) held to them here."""
from __future__ import annotations

import re
from pathlib import Path

import click
import pytest

from checker.cli.main import command
from checker.ftm.library import LIBRARY
from checker.gate.policy import parse_policy
from checker.planning.chain import CHAIN
from checker.planning.strategies import REGISTRY, STRATEGIES
from checker.reports.formats import RENDERERS
from checker.reports.report import ReportFormat
from checker.semantic_model.actions import KINDS
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
    cmd = command(" ".join(path))
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


def test_each_action_s_params_are_the_kinds_of_its_alloy_arguments() -> None:
    """The plan evaluation module calls each action with its Step's arguments by kind
    (`params`); an action's arguments (`args`) must be atoms of those kinds, in that order."""
    from checker.semantic_model.action_kinds import Change

    change = Change(removed=frozenset({"c"}), created=frozenset({"c"}), detached=frozenset({("/k", "c", "p")}),
                    attached=frozenset({("/k", "c", "p")}), degraded=frozenset({("c", "f")}),
                    upgraded=frozenset({("c", "f")}))
    for kind in KINDS:
        (action,) = kind.found(change)
        assert tuple(m[0] for m in kind.alloy_args(action)) == kind.params, kind.name


def test_the_evaluation_modules_declare_their_tables() -> None:
    """Each evaluation module declares exactly the sigs and fields its table names (the XML
    of its instances is written from the same table)."""
    from codegen.alloy import PLAN_EVALUATION_SIGS, render_evaluation_module, render_plan_evaluation_module
    from codegen.alloy_module import EVALUATION_SIGS

    for text, table in ((render_evaluation_module(), EVALUATION_SIGS),
                        (render_plan_evaluation_module(), PLAN_EVALUATION_SIGS)):
        declared = re.findall(r"^(?:abstract |one )*sig (\w+) (?:(?:in|extends) \w+ )?\{([^}]*)\}$", text, re.M)
        assert [(name, sorted(f.split(":")[0].strip() for f in body.split(",") if f.strip()))
                for name, body in declared] == [(s.name, sorted(f for f, _ in s.fields)) for s in table]


def test_the_executor_knows_each_action_by_the_registry_s_name_and_symbol() -> None:
    """The plan executor is standard library only, so its table of actions is a copy: held here
    to the registry (`checker.semantic_model.actions.KINDS`), its handlers and its symbols."""
    from reconf_ros.executor.handlers import HANDLERS
    from reconf_ros.executor.steps import SYMBOLS
    registry = {k.name: k.cls.symbol for k in KINDS}
    assert SYMBOLS == registry
    assert set(HANDLERS) == set(registry)
