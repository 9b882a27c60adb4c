"""Cancelling a judgement in Alloy from outside it: the language server stops a proof when the
file changes under it. A thread runs the judgement inside `cancellable(test)`; the analyzer's
work checks `checkpoint()` between instances and raises `Cancelled` once `test()` is true.
Outside `cancellable`, `checkpoint()` does nothing."""
from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Callable, Iterator


class Cancelled(Exception):
    """The judgement was cancelled between two of its instances."""


_local = threading.local()


@contextmanager
def cancellable(test: Callable[[], bool]) -> Iterator[None]:
    """Within this block, on this thread, `checkpoint()` raises `Cancelled` when `test()` is true."""
    before = getattr(_local, "test", None)
    _local.test = test
    try:
        yield
    finally:
        _local.test = before


def checkpoint() -> None:
    test = getattr(_local, "test", None)
    if test is not None and test():
        raise Cancelled()


def current_test() -> Callable[[], bool] | None:
    """The test of the `cancellable` block this thread is in (None outside one), for threads
    that work for it."""
    return getattr(_local, "test", None)
