"""The SAT solvers: one table (checker.alloy.bridge.SOLVER_TABLE) behind every `--solver`, the
README's list and the fallback."""
from __future__ import annotations

import os
import re

import click
import pytest
from click.testing import CliRunner

from checker.alloy.bridge import DEFAULT_SOLVER, FALLBACK_SOLVER, SOLVER_NAMES, SOLVER_TABLE
from checker.cli.main import main
from tests.examples_table import BY_NAME, ROOT


def solver_options(group: click.Group, prefix: str = "") -> dict[str, click.Option]:
    """Every command's --solver option, by the command's full name."""
    out: dict[str, click.Option] = {}
    for name in group.list_commands(click.Context(group)):
        cmd = group.get_command(click.Context(group), name)
        assert cmd is not None, name
        full = f"{prefix}{name}"
        if isinstance(cmd, click.Group):
            out.update(solver_options(cmd, full + " "))
            continue
        for p in cmd.params:
            if isinstance(p, click.Option) and "--solver" in p.opts:
                out[full] = p
    return out


def test_every_solver_option_offers_the_table() -> None:
    options = solver_options(main)
    assert {"check", "gate", "verify-meta-model"} <= set(options)
    for name, opt in options.items():
        assert isinstance(opt.type, click.Choice), name
        assert tuple(opt.type.choices) == SOLVER_NAMES, name
        assert opt.default == DEFAULT_SOLVER, name


def test_the_fallback_is_the_pure_java_solver_of_the_table() -> None:
    java = [s for s in SOLVER_TABLE if s.native is None]
    assert [s.analyzer for s in java] == [FALLBACK_SOLVER]
    assert len(set(SOLVER_NAMES)) == len(SOLVER_NAMES) and DEFAULT_SOLVER == SOLVER_NAMES[0]


@pytest.mark.parametrize("args", [
    ["check", BY_NAME["chatter"].file],
    ["gate", "--base", BY_NAME["chatter"].file, "--head", BY_NAME["chatter"].file],
    ["verify-meta-model"],
], ids=lambda a: a[0])
def test_an_unknown_solver_is_a_usage_error_naming_the_choices(args: list[str]) -> None:
    result = CliRunner().invoke(main, args + ["--solver", "nonsense"])
    assert result.exit_code == 2, result.output
    assert "Invalid value for '--solver': 'nonsense' is not one of" in result.stderr
    for name in SOLVER_NAMES:
        assert f"'{name}'" in result.stderr
    assert "RC302" not in result.output and "Traceback" not in result.output


def test_solver_names_are_not_case_sensitive() -> None:
    from checker.cli.verify_meta_model_cmd import verify_meta_model_cmd
    opt = next(p for p in verify_meta_model_cmd.params if p.name == "solver")
    assert opt.type.convert("Glucose", opt, None) == "glucose"   # type: ignore[union-attr]


def test_readme_lists_the_table() -> None:
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        text = " ".join(f.read().split())
    found = re.search(r"SAT solvers \(`--solver`\): ([^;]*);", text)
    assert found, "the README's sentence listing the SAT solvers"
    listed = [w.strip().removesuffix(" (default)") for w in found.group(1).split(",")]
    assert listed == list(SOLVER_NAMES)
    assert f"{DEFAULT_SOLVER} (default)" in found.group(1)
    assert f"falls back to {FALLBACK_SOLVER}" in text[found.end():found.end() + 200]


@pytest.mark.alloy
def test_every_offered_solver_works_here() -> None:
    """The table offers only solvers the analyzer runs on this platform: none falls back."""
    from checker.alloy.bridge import AlloyBridge
    bridge = AlloyBridge.get()
    module = "sig A {}\nrun { some A } for 2 expect 1\nrun { some A and no A } for 2 expect 0\n"
    for s in SOLVER_TABLE:
        assert bridge.usable_solver(s.name) == s.analyzer, s.name
        outcomes = bridge.run({"m.als": module}, "m.als", solver=s.name)
        assert [o.as_expected for o in outcomes] == [True, True], s.name
        assert {o.solver for o in outcomes} == {s.analyzer}
