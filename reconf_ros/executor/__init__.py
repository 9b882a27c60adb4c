"""The plan executor: carries out a verified plan on a running ROS 2 system, and shows that what
the system did matched the plan (docs/executor.md).

Generated plan scripts (`reconf plan ... -o plan.py`) embed these modules' text, joined into one
(`codegen.ros2.executor_source`, in the order of `EMBEDDED`), so they import nothing but the
standard library at the top; rclpy and the message packages are imported when a plan is applied.
Each module is one concern, readable in one sitting:

- `steps`: a plan document's parts as types (`Step`, the model's `TypedDict`s), the words for a step;
- `plan_states`: configurations (`State`) and a plan's states (`PlanStates`);
- `semantics`: satisfaction, the safety property and the actions' structural preconditions and
  effects over a plan's model (`Model`), the executor's own copy of `checker.semantic_model`'s;
- `status`: the status protocol the nodes publish on `/diagnostics`, and finding a component's node;
- `remote`: the per-host agents a hosts file names, and their processes (docs/hosts.md);
- `runtime`: the ROS side (`Runtime`): services with retries, the graph, the statuses;
- `naming`: which node is a component's (`Names`);
- `context`: what one run carries (`Context`);
- `replay`: the dry run;
- `observe`: reading the live system as a configuration;
- `conditions`: what a step waits for on the wire;
- `launcher`: the client side of the launcher, a fork server for new nodes;
- `processes`: starting and stopping a component's process, here or by its host's agent;
- `handlers`: the six actions, one handler each (`HANDLERS`);
- `run_report`: the run report, and what a failure says;
- `run`: a run of a plan (`Executor`);
- `script`: the plan script's command line (`main`).

`snapshot` (the live graph as data, for `reconf discover` and `reconf drift`) lives here because
it reads the system through the same `Runtime`; plan scripts do not embed it.
"""
from __future__ import annotations

EMBEDDED = ("steps", "plan_states", "semantics", "status", "remote", "runtime", "naming", "context", "replay", "observe",
            "conditions", "launcher", "processes", "handlers", "run_report", "run", "script")
