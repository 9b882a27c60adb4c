"""`reconf daemon start|stop|status|run`: a warm analyzer for `reconf check` (checker.editor.warm),
as `dmypy` is for mypy. `reconf lsp` serves the same while an editor runs it."""
from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from typing import Any, Optional

import click

from checker.alloy.evaluate import start_early
from checker.cli.common import EXIT_BAD_INPUT, EXIT_OK, console
from checker.editor import warm

START_TIMEOUT = 60.0   # seconds for a started daemon to answer


def runner_for(group: click.Command) -> warm.Runner:
    """Run `reconf ARGV` in this process, as a fresh process would: its output and exit code."""
    def run(argv: list[str]) -> tuple[str, str, int]:
        out, err = io.StringIO(), io.StringIO()
        code: Any = 0
        with redirect_stdout(out), redirect_stderr(err):
            try:
                group.main(argv, prog_name="reconf", standalone_mode=True)
            except SystemExit as e:
                code = e.code
        exit_code = code if isinstance(code, int) else (0 if code is None else EXIT_BAD_INPUT)
        return out.getvalue(), err.getvalue(), exit_code
    return run


def serve_in_background(label: str, on_stop: Optional[Any] = None) -> Optional[warm.Server]:
    """Serve `reconf check` from this process on a thread, unless another server does already."""
    server = warm.Server(runner_for(click.get_current_context().find_root().command), label, on_stop)
    return server if server.bind() and server.start() else None


@click.group("daemon")
def daemon_group() -> None:
    """A warm analyzer for `reconf check`: one Python and one JVM kept running, so that a check
    starts in milliseconds (docs/editor.md). `reconf check` uses it (or a running `reconf lsp`)
    when there is one, and says so on its timing line; RECONF_NO_WARM=1 keeps a check cold.

    \b
    Exit codes: 0 done (also: nothing to stop), 2 it could not be started.
    """


@daemon_group.command("run")
def run_cmd() -> None:
    """Serve in the foreground until `reconf daemon stop` or a signal."""
    server = warm.Server(runner_for(click.get_current_context().find_root().command), "reconf daemon")
    if not server.bind():
        console().print(f"a warm analyzer already serves at {server.path}")
        sys.exit(EXIT_BAD_INPUT)
    signal.signal(signal.SIGTERM, lambda *_: server.close())
    start_early()
    console().print(f"reconf daemon (pid {os.getpid()}) serves `reconf check` at {server.path}")
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        server.close()
    sys.exit(EXIT_OK)


@daemon_group.command("start")
def start_cmd() -> None:
    """Start the daemon in the background (nothing to do if one runs)."""
    running = warm.status()
    if running is not None:
        console().print(f"already running: {running['by']}")
        sys.exit(EXIT_OK)
    log = os.path.join(os.path.dirname(warm.socket_path()), "daemon.log")
    os.makedirs(os.path.dirname(log), mode=0o700, exist_ok=True)
    with open(log, "ab") as out:
        proc = subprocess.Popen([sys.executable, "-m", "checker", "daemon", "run"], stdin=subprocess.DEVNULL,
                                stdout=out, stderr=out, start_new_session=True, cwd="/")
    deadline = time.monotonic() + START_TIMEOUT
    while time.monotonic() < deadline and proc.poll() is None:
        if warm.status() is not None:
            console().print(f"reconf daemon started (pid {proc.pid}); it serves `reconf check` at {warm.socket_path()}")
            sys.exit(EXIT_OK)
        time.sleep(0.05)
    console().print(f"[bold red]✗[/] the daemon did not start; its log: {log}")
    sys.exit(EXIT_BAD_INPUT)


@daemon_group.command("stop")
def stop_cmd() -> None:
    """Stop the daemon (or the warm analyzer of a running `reconf lsp`)."""
    pid = warm.stop()
    console().print(f"stopped the warm analyzer (pid {pid})" if pid else "no warm analyzer was running")
    sys.exit(EXIT_OK)


@daemon_group.command("status")
def status_cmd() -> None:
    """Say whether a warm analyzer runs, and which."""
    running = warm.status()
    if running is None:
        console().print(f"no warm analyzer runs (socket {warm.socket_path()}); `reconf check` runs cold")
    else:
        up = time.time() - running["since"]
        console().print(f"{running['by']}: up {up:.0f} s, {running['served']} checks served, at {warm.socket_path()}")
    sys.exit(EXIT_OK)
