"""Pause Python's cyclic garbage collector around work that builds many long-lived objects.

An architecture's IR (and the engine's graph over it) is hundreds of thousands of small
objects that all live on; with the collector running, every full collection walks them all
again, which makes reading and checking large systems grow faster than linearly."""
from __future__ import annotations

import gc
from contextlib import contextmanager
from typing import Iterator


@contextmanager
def gc_paused() -> Iterator[None]:
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()
