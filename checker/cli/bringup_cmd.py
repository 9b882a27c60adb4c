"""`reconf up PATHS` and `reconf down PATHS`: start a system from nothing, or stop it, by a
verified plan carried out by the plan scripts' executor (docs/executor.md#bring-up-and-tear-down).

The executor's options are the plan script's own, read from `reconf_ros.executor.script.arguments`, so
`reconf up` and `python plan.py` accept the same ones, checked before anything is planned. With
`-o` the script is written instead, and nothing is applied.
"""
from __future__ import annotations

import argparse
import contextlib
import sys
from typing import Any, Callable, NoReturn

import click

from checker.cli.common import guarded
from checker.cli.inputs import exclude_option, expand, nothing_left, paths_argument
from checker.cli.plan_cmd import run
from checker.cli.plan_options import with_plan_options
from checker.planning.bringup import plan_down, plan_up
from reconf_dsl.loader import Sources, load
from reconf_ros.executor import script

__all__ = ["up_cmd", "down_cmd"]

_HIDDEN = {"help", "quiet_list", "cwd"}
_TYPES: dict[Any, click.ParamType] = {float: click.FloatRange(min=0, min_open=True),   # timeouts > 0
                                      int: click.IntRange(min=0)}                        # steps ≥ 0


def _script_actions() -> list[argparse.Action]:
    # argparse keeps a parser's options in `_actions`; the parser is the executor's, built here only to be read
    parser = script.arguments({"system": "", "fingerprint": ""})
    return [a for a in parser._actions if a.dest not in _HIDDEN]


def _click_option(a: argparse.Action) -> Callable[[Any], Any]:
    flags = [f for f in a.option_strings if f != "-y"] + (["-y"] if "-y" in a.option_strings else [])
    name = "run_" + a.dest
    if a.nargs == 0:
        return click.option(*flags, name, is_flag=True, help=a.help)
    if a.nargs == "?":
        return click.option(*flags, name, is_flag=False, flag_value=a.const, default=None, metavar=a.metavar,
                            help=a.help)
    kind = click.FloatRange(min=0) if a.type is float and a.default == 0 else _TYPES.get(a.type)   # a pause: 0 is none
    return click.option(*flags, name, type=kind or click.STRING, default=a.default,
                        show_default=bool(a.default), metavar=a.metavar, help=a.help)


def with_script_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    for a in reversed(_script_actions()):
        fn = _click_option(a)(fn)
    return fn


def script_argv(opts: dict[str, Any]) -> list[str]:
    """The plan script's arguments for the `run_*` options given (defaults left out)."""
    argv: list[str] = []
    for a in _script_actions():
        value = opts.pop("run_" + a.dest)
        flag = a.option_strings[0]
        if a.nargs == 0:
            argv += [flag] if value else []
        elif value is not None and value != a.default:
            argv.append(f"{flag}={value}")
    return argv


def applier(argv: list[str], prog: str = "reconf up/down") -> Callable[[dict[str, Any]], int]:
    """Carry out a plan document with the executor, its output on stderr (stdout is for the
    machine format). The step range is checked against the plan first, as a usage error."""
    def apply(doc: dict[str, Any]) -> int:
        parser = script.arguments(doc)
        parser.prog = prog
        setattr(parser, "error", _usage)
        script.parse(doc, argv, parser)
        with contextlib.redirect_stdout(sys.stderr):
            return script.main(doc, argv)
    return apply


def _usage(message: str) -> NoReturn:
    raise click.UsageError(message)


def _bring(verb: str, plan: Callable[..., Any], files: tuple[str, ...], exclude: tuple[str, ...], sources: Sources,
           opts: dict[str, Any]) -> None:
    argv = script_argv(opts)
    system = load(expand(files, exclude) or nothing_left(files), sources)
    run(f"bring {system.name} {verb}", system, lambda fb: plan(system, opts["strategy"], fallback=fb), sources,
        chain=True, apply=applier(argv), **opts)


@click.command("up")
@paths_argument
@exclude_option
@with_plan_options
@with_script_options
@guarded("up")
def up_cmd(files: tuple[str, ...], exclude: tuple[str, ...], sources: Sources, **opts: Any) -> None:
    """Start the system PATHs deploy from nothing: create, attach and upgrade in a safe order, by a
    verified plan, on the running ROS 2 graph (or, with -o, write that plan's script)."""
    _bring("up", plan_up, files, exclude, sources, opts)


@click.command("down")
@paths_argument
@exclude_option
@with_plan_options
@with_script_options
@guarded("down")
def down_cmd(files: tuple[str, ...], exclude: tuple[str, ...], sources: Sources, **opts: Any) -> None:
    """Stop the system PATHs deploy: degrade, detach and remove in a safe order, by a verified plan
    (or, with -o, write that plan's script)."""
    _bring("down", plan_down, files, exclude, sources, opts)
