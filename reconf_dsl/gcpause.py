"""Pause Python's cyclic garbage collector around work that builds many long-lived objects.

An architecture's IR (and the engine's graph over it) is hundreds of thousands of small
objects that all live on; with the collector running, every full collection walks them all
again, which makes reading and checking large systems grow faster than linearly. When the
pause ends, what was built is moved to the collector's permanent generation (`gc.freeze`),
so that the first collection afterwards does not walk it all either; reference counting
still frees these objects as usual."""
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
            gc.freeze()
            gc.enable()
