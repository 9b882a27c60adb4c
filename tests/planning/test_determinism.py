"""Every planner gives the same plan in every process: none takes an order from a set of names,
whose iteration order follows the string hashes Python seeds per process. (FTM transitions are
held to the same in tests/ftm/test_transition.py.)"""
from __future__ import annotations

import json
import os
import subprocess
import sys

from tests.examples_table import ROOT

# each planner, each strategy, on an example of its own; one line of JSON per plan
PLANS = """import json
from bench.gen import generate
from checker.planning.bringup import plan_down, plan_up
from checker.planning.operations import plan_migrate, plan_remove, plan_replace
from reconf_dsl.loader import load, load_text

def ex(name):
    return load([f"examples/{name}.arch"])

def show(label, plan):
    print(json.dumps([label, [a.to_dict() for a in plan.steps], plan.batches]))

hubs = {n: load_text(generate("fanin", n, seed=1 if n == 12 else 3, version=True)) for n in (12, 30)}
for strategy in ("default", "paper", "exhaustive"):
    show(f"chatter {strategy}", plan_replace(ex("chatter"), "talker", "talker_v2", strategy))
    show(f"chain5 {strategy}", plan_replace(ex("chain5"), "stage0", "stage0_v2", strategy))
    show(f"redundant {strategy}", plan_replace(ex("redundant"), "lidar_rear", "lidar_rear_v2", strategy))
    n = 12 if strategy == "exhaustive" else 30     # exhaustive on 30 took a minute
    show(f"fanin-{n} {strategy}", plan_replace(hubs[n], "hub", "hub_v2", strategy))
show("robot remove", plan_remove(ex("robot"), "obstacle_detector"))
show("chatter migrate", plan_migrate(ex("chatter"), ex("chatter_migrated")))
show("robot up", plan_up(ex("robot")))
show("robot down", plan_down(ex("robot")))
"""


def test_every_planner_s_plan_does_not_depend_on_string_hashing() -> None:
    outputs = []
    for seed in ("1", "2", "3"):
        res = subprocess.run([sys.executable, "-c", PLANS], capture_output=True, text=True, cwd=ROOT,
                             env={**os.environ, "PYTHONHASHSEED": seed}, timeout=300)
        assert res.returncode == 0, res.stderr[-2000:]
        outputs.append([json.loads(line) for line in res.stdout.splitlines()])
    assert len(outputs[0]) == 16 and all(steps for _, steps, _ in outputs[0])
    for other in outputs[1:]:
        for (label, steps, batches), (_, steps2, batches2) in zip(outputs[0], other):
            assert (steps, batches) == (steps2, batches2), f"{label}: the plan differs between two processes"
