"""How long this process has run (standard library only: the light client of a warm analyzer
imports it before, and instead of, the rest of reconf)."""
from __future__ import annotations

import os


def process_age() -> float:
    """Seconds since this process started (the interpreter's start-up and imports included),
    from /proc; 0 where that cannot be read."""
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            started = int(f.read().rsplit(")", 1)[1].split()[19]) / os.sysconf("SC_CLK_TCK")
        with open("/proc/uptime", encoding="ascii") as f:
            return max(0.0, float(f.read().split()[0]) - started)
    except (OSError, ValueError, IndexError):
        return 0.0
