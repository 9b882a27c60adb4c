"""The `reconf` program: `reconf check …` is first offered to a warm analyzer (a running `reconf
daemon` or `reconf lsp`, checker.editor.warm), as `dmypy run` is, with its arguments as they
were typed; when none answers, or for any other command, the command line (`checker.cli.main`)
runs here. Only the standard library and checker.editor.warm are imported before that, so a warm
check does not pay for loading reconf.

A check that runs here with the Alloy proof starts the JVM first, on a thread of its own
(`checker.alloy.jvm.start_soon`), so that the JVM starts while the rest of reconf is imported;
as a process that judges once and ends, its JVM stops at C1 (`jvm.QUICK_JIT`)."""
from __future__ import annotations

import gc
import sys

GLOBAL_FLAGS = ("--allow-includes-outside",)


def _is_check(argv: list[str]) -> bool:
    rest = [a for a in argv if a not in GLOBAL_FLAGS]
    return bool(rest) and rest[0] == "check" and "-" not in rest[1:] and not {"-h", "--help"} & set(rest)


def _engine(argv: list[str]) -> str:
    """The value of the last --engine option (click's rule), "both" without one."""
    engine = "both"
    for i, arg in enumerate(argv):
        if arg == "--engine" and i + 1 < len(argv):
            engine = argv[i + 1]
        elif arg.startswith("--engine="):
            engine = arg.split("=", 1)[1]
    return engine


def _start_analyzer(argv: list[str]) -> None:
    """Start the JVM now, for a check the Alloy Analyzer judges."""
    if _engine(argv) == "python":
        return
    from checker.alloy import jvm

    jvm.prefer_quick(True)
    jvm.start_soon(then=_evaluation_module)


def _evaluation_module() -> None:
    """Parse the evaluation module and run the analyzer once (`evaluate.prepare`), on the
    JVM's thread once it has started (the modules this imports are imported by this thread and
    the main one at once: the project has no import cycle, so each waits for the other where
    they meet)."""
    from checker.alloy.bridge import get_backend
    from checker.alloy.evaluate import prepare

    prepare(get_backend())


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
        # A check that runs here ends once it has judged: Python's cyclic collector would walk
        # the architecture's hundreds of thousands of objects again and again to free cycles
        # that hardly exist (10,000 components: 0.6 s of 6.6; peak memory the same). Reference
        # counting frees objects as usual.
        gc.disable()
        _start_analyzer([a for a in argv if a not in GLOBAL_FLAGS])
    from checker.cli.main import main as reconf  # the whole command line, when no warm analyzer answered

    reconf()
