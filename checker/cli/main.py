"""The `reconf` command line. Human output goes to stderr through rich, machine output to stdout.

Exit codes: 0 safe / done, 1 unsafe / no safe plan, 2 bad input, usage, missing dependency,
resource failure or internal error; with `--detailed-exitcode`, `plan` and `gate` exit 3 for a safe
change that has steps (0 then means nothing to do). See docs/exit-codes.md."""
from __future__ import annotations

import click

from checker.cli.alloy_cmd import alloy_cmd
from checker.cli.bringup_cmd import down_cmd, up_cmd
from checker.cli.check_cmd import check
from checker.cli.daemon_cmd import daemon_group
from checker.cli.discover_cmd import discover_cmd
from checker.cli.drift_cmd import drift_cmd
from checker.cli.fmt_cmd import fmt_cmd
from checker.cli.ftm_cmd import ftm_group, transition_cmd
from checker.cli.gate_cmd import gate_cmd
from checker.cli.graph_cmd import graph, graph_plan
from checker.cli.lsp_cmd import lsp_cmd
from checker.cli.modes_cmd import modes_group
from checker.cli.plan_cmd import plan
from checker.cli.recover_cmd import recover_cmd
from checker.cli.verify_model_cmd import verify_model_cmd
from reconf_dsl import loader
from reconf_dsl.loader import ALLOW_OUTSIDE_ENV


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
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


plan.add_command(transition_cmd)
for command in (check, alloy_cmd, graph, graph_plan, plan, recover_cmd, up_cmd, down_cmd, gate_cmd, ftm_group,
                fmt_cmd, modes_group, discover_cmd, drift_cmd, verify_model_cmd, lsp_cmd,
                daemon_group):
    main.add_command(command)
