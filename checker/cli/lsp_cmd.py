"""`reconf lsp`: the language server, over standard input and output (docs/editor.md). The
server is `checker.editor`; this module starts it and keeps standard output for the protocol
alone (whatever else writes there, the JVM included, goes to standard error)."""
from __future__ import annotations

import os
import sys

import click

from checker.cli.common import EXIT_OK


def _protocol_streams() -> tuple[object, object]:
    """Standard input, and a copy of standard output for the protocol; file descriptor 1 then
    points at standard error, so that no stray write can break a message."""
    sys.stdout.flush()
    out = os.fdopen(os.dup(1), "wb", buffering=0)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return sys.stdin.buffer, out


@click.command("lsp")
@click.option("--stdio", is_flag=True, help="speak over standard input and output (the default; editors pass it)")
@click.option("--no-alloy", is_flag=True, help="no Alloy proof on save: diagnostics from the Python engine alone")
@click.option("--no-warm", is_flag=True,
              help="do not serve `reconf check` from this session (by default it does, over a local socket)")
def lsp_cmd(stdio: bool, no_alloy: bool, no_warm: bool) -> None:
    """Run the language server for .arch files: diagnostics as you type, the Alloy proof on save,
    go to definition, references, hover, symbols, formatting and completion.

    An editor starts it (docs/editor.md shows VS Code, Neovim and Emacs); it ends when the
    editor says so. Exit code 0 when it ends normally.
    """
    del stdio
    from importlib.metadata import version

    from checker.editor.protocol import make_server  # here for start-up time: pygls loads for this command alone
    server, session = make_server(alloy=not no_alloy, version=version("reconf"))
    session.warm = not no_warm
    stdin, stdout = _protocol_streams()
    server.start_io(stdin, stdout)  # type: ignore[arg-type]
    sys.exit(EXIT_OK)
