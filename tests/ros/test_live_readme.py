"""The README's live walkthroughs (each block after `<!-- live: ... -->`) run as written, line by
line, on a live graph in a domain of its own: up, discover, check, drift, a recording and the
check against it, down; then a crash and an interruption, and the recoveries from them. Each
line must exit as its comment says, and say what the README says it shows; the nodes the
commands started must have exited once down has finalized them."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from reconf_ros.tools.livetest import LiveSystem, alive

from ..test_readme import LIVE, README

TIMEOUT = 120
# What the commands of each walkthrough must print (values, not only an exit status), in order:
# a command that starts with the next entry's prefix is held to that entry.
SHOWS: list[list[tuple[str, tuple[str, ...]]]] = [
    [("reconf up", ("reconf will bring chatter up in 6 steps",)),        # and, the second time, is refused:
     ("reconf up", ("does not match",)),
     ("reconf discover", ("wrote found.arch: 2 reconf nodes, 0 placeholders",)),
     ("reconf check found.arch", ("✓ safe: chatter — 2 components, 1 connector, 1 assumption, all hold",)),
     ("reconf drift", ("✓ in sync: chatter — 2 components against",)),    # and the test's status watcher
     ("python -m reconf_ros.tools.record", ("wrote rec:",)),
     ("reconf check examples/chatter.arch --bag rec", ("judged against 4 rates, all met",)),
     ("reconf down", ("reconf will bring chatter down in 5 steps",))],
    [("reconf up", ("reconf will bring chatter up in 6 steps",)),
     ("reconf drift", ("component talker has no node in the live system",)),
     ("reconf recover --live", ("1. ↓ degrade listener.listen", "create talker (all functionalities degraded)")),
     ("reconf plan replace", ("Wrote plan.py",)),
     ("timeout --preserve-status -s INT", ("INTERRUPTED by SIGINT", "report: reconf-chatter-interrupted.json")),
     ("reconf timeline", ("chatter:", "steps timed, interrupted", "create talker_v2")),
     ("reconf recover reconf-chatter-interrupted.json", ("recover reconf-chatter-interrupted.json → the start",)),
     ("reconf drift", ("✓ in sync: chatter — 2 components against",)),
     ("reconf down", ("reconf will bring chatter down in 5 steps",))],
]


def walkthroughs() -> list[list[tuple[int, str]]]:
    """Each block after a `<!-- live: ... -->` line: its command lines, with their line numbers."""
    lines = Path(README).read_text(encoding="utf-8").splitlines()
    blocks = []
    for first in (i for i, ln in enumerate(lines) if ln.startswith(LIVE)):
        start = first + 2
        end = next(i for i in range(start, len(lines)) if lines[i].startswith("```"))
        blocks.append([(i + 1, ln) for i, ln in enumerate(lines[start:end], start) if ln.strip()])
    return blocks


def test_every_walkthrough_is_held_to_what_it_shows() -> None:
    assert len(walkthroughs()) == len(SHOWS)


@pytest.mark.parametrize("block", range(len(SHOWS)), ids=["model-and-reality", "failures"])
def test_the_readme_walkthrough_runs_on_a_live_graph(live: LiveSystem, block: int) -> None:
    shutil.copytree(Path(README).parent / "examples", live.dir / "examples")
    env = dict(live.env, PATH=os.path.dirname(sys.executable) + os.pathsep + live.env.get("PATH", ""))
    shows, started = list(SHOWS[block]), set()
    for number, line in walkthroughs()[block]:
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
        code = re.search(r"exit (\d+)\b", line)
        assert done.returncode == (int(code.group(1)) if code else 0), said
        if shows and command.startswith(shows[0][0]):
            for text in shows.pop(0)[1]:
                assert text in " ".join(out.split()), said
    assert shows == [], f"not shown: {shows}"
    if block == 0:
        assert live.watched_violations() == []      # the failures' walkthrough has a crash in it
        assert len(started) == 2                    # up started the talker and the listener…
    end = time.monotonic() + 10
    while any(alive(p) for p in started) and time.monotonic() < end:
        time.sleep(0.1)
    assert not any(alive(p) for p in started), "a node did not exit once down finalized it"   # …down ended them
