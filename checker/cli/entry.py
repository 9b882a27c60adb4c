"""The `reconf` program: `reconf check …` is first offered to a warm analyzer (a running `reconf
daemon` or `reconf lsp`, checker.editor.warm), as `dmypy run` is, with its arguments as they
were typed; when none answers, or for any other command, the command line (`checker.cli.main`)
runs here. Only the standard library and checker.editor.warm are imported before that, so a warm
check does not pay for loading reconf."""
from __future__ import annotations

import sys

GLOBAL_FLAGS = ("--allow-includes-outside",)


def _is_check(argv: list[str]) -> bool:
    rest = [a for a in argv if a not in GLOBAL_FLAGS]
    return bool(rest) and rest[0] == "check" and "-" not in rest[1:] and not {"-h", "--help"} & set(rest)


def main() -> None:
    argv = sys.argv[1:]
    if _is_check(argv):
        from checker.editor import warm
        from checker.reports.clock import process_age

        if warm.wanted():
            answer = warm.ask(argv, process_age(), sys.stderr.isatty())
            if answer is not None:
                sys.stdout.write(answer.stdout)
                sys.stdout.flush()
                sys.stderr.write(answer.stderr)
                sys.stderr.flush()
                sys.exit(answer.exit)
    from checker.cli.main import main as reconf  # the whole command line, when no warm analyzer answered

    reconf()
