"""A spinner on stderr while long work runs (big Alloy checks, plan verification).

Shown only to a person: off when stderr is not a terminal, in CI (`CI` set), with `NO_COLOR`
set, with `TERM=dumb`, or with `RECONF_NO_PROGRESS` set."""
from __future__ import annotations

import contextlib
import os
import sys
from typing import Callable, Iterator, Mapping, Optional, TextIO


def enabled(stream: Optional[TextIO] = None, env: Optional[Mapping[str, str]] = None) -> bool:
    stream = stream if stream is not None else sys.stderr
    env = env if env is not None else os.environ
    if any(env.get(k) for k in ("CI", "NO_COLOR", "RECONF_NO_PROGRESS", "GITHUB_ACTIONS")):
        return False
    if env.get("TERM") == "dumb":
        return False
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # a closed stream
        return False


@contextlib.contextmanager
def status(message: str) -> Iterator[Callable[[str], None]]:
    """`with status("checking in Alloy…") as say:` shows a spinner with the message while the
    block runs; `say(text)` replaces the message (a no-op when progress is off)."""
    if not enabled():
        yield lambda text: None
        return
    from rich.console import Console
    with Console(stderr=True).status(message, spinner="dots") as shown:
        yield lambda text: shown.update(text)
