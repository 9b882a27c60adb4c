"""`reconf alloy FILES`: the Alloy instance module of the deployed configuration, to open in the
Alloy GUI."""
from __future__ import annotations

from typing import Optional

import click

from checker.cli.common import console, files_argument, guarded, write_atomically
from checker.reports.report import OutputFormat
from checker.semantic_model.actions import is_valid
from checker.semantic_model.config import Configuration
from codegen.alloy import render_instance
from reconf_dsl.loader import Sources, load


@click.command("alloy")
@files_argument
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="write the module here instead of stdout")
@guarded("alloy")
def alloy_cmd(files: tuple[str, ...], output: Optional[str], sources: Sources,
              output_format: OutputFormat = OutputFormat.TEXT) -> None:
    """Write the Alloy instance module of FILES' deployed configuration (open it in the Alloy GUI)."""

    system = load(list(files), sources)
    config = Configuration.initial(system)
    text, _ = render_instance(system, config, valid=is_valid(system, config))
    if output:
        write_atomically(output, text)
        console().print(f"wrote {output}: `run Verdict` shows the configuration and what fails")
    else:
        click.echo(text, nl=False)
