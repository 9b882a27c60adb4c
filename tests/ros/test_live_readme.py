"""The README's live walkthrough (the block after `<!-- live: ... -->`) run as written, line by
line, on a live graph in a domain of its own: up, discover, check, drift, a recording and the
check against it, down. Each line must exit as its comment says, and say what the README says
it shows; the nodes up started must have exited once down has finalized them."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from reconf_ros.tools.livetest import LiveSystem

from ..test_readme import LIVE, README

TIMEOUT = 120
# What each command of the walkthrough must print (a value, not only an exit status).
SHOWS = {
    "reconf up": "reconf will bring chatter up in 6 steps",           # and, the second time, is refused:
    "reconf discover": "wrote found.arch: 2 reconf nodes, 0 placeholders",
    "reconf check found.arch": "✓ safe: chatter — 2 components, 1 connector, 1 assumption, all hold",
    "reconf drift": "✓ in sync: chatter — 2 components against",           # and the test's status watcher
    "python -m reconf_ros.tools.record": "wrote rec:",
    "reconf check examples/chatter.arch --bag rec": "judged against 4 rates, all met",
    "reconf down": "reconf will bring chatter down in 5 steps",
}


def walkthrough() -> list[tuple[int, str]]:
    lines = Path(README).read_text(encoding="utf-8").splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(LIVE)) + 2
    end = next(i for i in range(start, len(lines)) if lines[i].startswith("```"))
    return [(i + 1, ln) for i, ln in enumerate(lines[start:end], start) if ln.strip()]


def test_the_readme_walkthrough_runs_on_a_live_graph(live: LiveSystem) -> None:
    shutil.copytree(Path(README).parent / "examples", live.dir / "examples")
    env = dict(live.env, PATH=os.path.dirname(sys.executable) + os.pathsep + live.env.get("PATH", ""))
    shown, started = set(), set()
    for number, line in walkthrough():
        command = line.split("  #")[0].strip()
        if command.startswith(". .venv/bin/activate"):
            continue                                     # the PATH above is the venv's
        if command.startswith("export ROS_DOMAIN_ID="):
            command = command.split(";", 1)[1]           # the test's own domain, not the README's
        done = subprocess.run(["bash", "-c", command], cwd=live.dir, env=env, capture_output=True, text=True,
                              timeout=TIMEOUT)
        out = done.stdout + done.stderr
        started |= {int(p) for p in re.findall(r"started \w+: pid (\d+)", out)}
        live.pids |= started                                                        # ended by the fixture
        said = f"README.md:{number}: {command}\n{out[-3000:]}"
        assert "Traceback" not in out, said
        assert done.returncode == (1 if re.search(r"exit 1\b", line) else 0), said
        if command.startswith("reconf up") and done.returncode:
            assert "does not match" in out, said
        for prefix, text in SHOWS.items():
            if command.startswith(prefix):
                assert text in " ".join(out.split()), said
                shown.add(prefix)
    assert shown == set(SHOWS)
    assert live.watched_violations() == []
    assert len(started) == 2                            # up started the talker and the listener…
    end = time.monotonic() + 10
    while any(alive(p) for p in started) and time.monotonic() < end:
        time.sleep(0.1)
    assert not any(alive(p) for p in started), "a node did not exit once down finalized it"   # …down ended them


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            return fh.read().split(") ", 1)[1][0] != "Z"     # a zombie has exited, its parent not told yet
    except (FileNotFoundError, IndexError):
        return False
