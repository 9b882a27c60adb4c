"""The `reconf` command line. Human output goes to stderr through rich, machine output to stdout.

Exit codes: 0 safe / done, 1 unsafe / no safe plan, 2 bad input, usage, missing dependency,
resource failure or internal error; with `--detailed-exitcode`, `plan` and `gate` exit 3 for a safe
change that has steps (0 then means nothing to do). See docs/exit-codes.md."""
from __future__ import annotations

import importlib
from typing import Optional

import click

from reconf_dsl import loader
from reconf_dsl.loader import ALLOW_OUTSIDE_ENV

# Every command: its name -> the module and the name it is defined under, and the commands a
# group takes from other modules. A command's module is imported when the command runs (or
# help lists it): `reconf check` does not load planning, the runtime's tools or pygls.
COMMANDS: dict[str, tuple[str, str, tuple[tuple[str, str], ...]]] = {
    "check": ("checker.cli.check_cmd", "check", ()),
    "alloy": ("checker.cli.alloy_cmd", "alloy_cmd", ()),
    "graph": ("checker.cli.graph_cmd", "graph", ()),
    "graph-plan": ("checker.cli.graph_cmd", "graph_plan", ()),
    "plan": ("checker.cli.plan_cmd", "plan", (("checker.cli.ftm_cmd", "transition_cmd"),)),
    "recover": ("checker.cli.recover_cmd", "recover_cmd", ()),
    "timeline": ("checker.cli.timeline_cmd", "timeline_cmd", ()),
    "up": ("checker.cli.bringup_cmd", "up_cmd", ()),
    "down": ("checker.cli.bringup_cmd", "down_cmd", ()),
    "gate": ("checker.cli.gate_cmd", "gate_cmd", ()),
    "ftm": ("checker.cli.ftm_cmd", "ftm_group", ()),
    "fmt": ("checker.cli.fmt_cmd", "fmt_cmd", ()),
    "modes": ("checker.cli.modes_cmd", "modes_group", ()),
    "discover": ("checker.cli.discover_cmd", "discover_cmd", ()),
    "drift": ("checker.cli.drift_cmd", "drift_cmd", ()),
    "verify-meta-model": ("checker.cli.verify_meta_model_cmd", "verify_meta_model_cmd", ()),
    "lsp": ("checker.cli.lsp_cmd", "lsp_cmd", ()),
    "daemon": ("checker.cli.daemon_cmd", "daemon_group", ()),
}

# Former names a command still answers to (not listed by help): scripts written for them keep working.
FORMER_NAMES = {"verify-model": "verify-meta-model"}


def _attribute(module: str, name: str) -> click.Command:
    found = getattr(importlib.import_module(module), name)
    assert isinstance(found, click.Command), f"{module}.{name} is not a command"
    return found


class Commands(click.Group):
    """The group of `COMMANDS`, each loaded on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: Optional[click.Context], cmd_name: str) -> Optional[click.Command]:
        cmd_name = FORMER_NAMES.get(cmd_name, cmd_name)
        if cmd_name not in COMMANDS:
            return None
        if cmd_name not in self.commands:
            module, name, extra = COMMANDS[cmd_name]
            command = _attribute(module, name)
            if isinstance(command, click.Group):
                for sub_module, sub_name in extra:
                    sub = _attribute(sub_module, sub_name)
                    if sub.name not in command.commands:
                        command.add_command(sub)
            self.commands[cmd_name] = command
        return self.commands[cmd_name]


@click.group(cls=Commands, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="reconf")
@click.option("--allow-includes-outside", is_flag=True, envvar=ALLOW_OUTSIDE_ENV,
              help="follow includes that lead outside the directory tree of the file named "
                   "(env RECONF_ALLOW_INCLUDES_OUTSIDE=1)")
def main(allow_includes_outside: bool) -> None:
    """reconf: check ROS 2 architectures and plan safe run-time reconfigurations.

    \b
    Exit codes (docs/exit-codes.md): 0 safe or done, 1 unsafe or no safe plan,
                2 not answered: bad input, usage, a missing dependency, an output
                  that cannot be written, or an internal error,
                3 with --detailed-exitcode: a safe change with steps.
    """
    loader.settings.allow_includes_outside = allow_includes_outside


def command(path: str) -> click.Command:
    """The command `path` ("plan replace"), its module loaded."""
    cmd: click.Command = main
    for name in path.split():
        assert isinstance(cmd, click.Group), path
        found = cmd.get_command(None, name)  # type: ignore[arg-type]
        assert found is not None, path
        cmd = found
    return cmd
