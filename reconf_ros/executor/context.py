"""What one run of a plan carries from step to step: the plan, its model and states, the
script's options, the ROS runtime, the components' nodes, the processes the run started, and
where its words go."""
from __future__ import annotations

import argparse
import datetime
import os
from dataclasses import dataclass, field
from typing import Any, Optional, Protocol

from .naming import Names
from .plan_states import PlanStates
from .semantics import Model
from .steps import Step, plan_steps


class Writer(Protocol):
    """Where a run's words go: a text stream, or a manager's stream to its client."""

    def write(self, text: str, /) -> int: ...

    def flush(self) -> None: ...


@dataclass
class Started:
    """A process this run started for a component's create."""
    pid: int
    log: str
    command: str
    node: str
    proc: Any                        # its subprocess.Popen, or the launcher's handle
    ended: Optional[int] = None      # its exit status, once a remove has waited for it

    def to_doc(self) -> dict[str, Any]:
        doc = {"pid": self.pid, "log": self.log, "command": self.command, "node": self.node}
        return doc if self.ended is None else {**doc, "ended": self.ended}


@dataclass
class StepTiming:
    """When a step began (wall clock, for the report) and how long it took."""
    step: int
    at: float
    seconds: float
    ok: bool
    action: str = ""

    def to_doc(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"step": self.step, "at": self.at, "seconds": self.seconds, "ok": self.ok}
        return {**doc, "action": self.action} if self.ok else doc


@dataclass
class Context:
    """One run of a plan document on the live system."""
    doc: dict[str, Any]
    args: argparse.Namespace
    out: Writer
    err: Writer
    rt: Any = None                   # the Runtime, once the run has one
    launcher: Any = None             # a manager's fork server (docs/executor.md#launcher)
    started: dict[str, Started] = field(default_factory=dict)
    touched: set[str] = field(default_factory=set)
    timings: list[StepTiming] = field(default_factory=list)
    failure: str = ""                # why the last step failed

    def __post_init__(self) -> None:
        self.model = Model(self.doc["model"])
        self.steps: list[Step] = plan_steps(self.doc)
        self.states = PlanStates(self.doc["plan"])
        self.runs: dict[str, Optional[str]] = {c["name"]: c.get("run") for c in self.doc["model"]["components"]}
        self.log_dir: str = self.args.log_dir or os.path.join(
            "reconf-logs", f"{self.doc['system']}-{datetime.datetime.now().strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")
        self._names: Optional[Names] = None

    @property
    def names(self) -> Names:
        """The components' nodes (made with the runtime, which knows the namespace and the graph)."""
        if self._names is None:
            self._names = Names(self.rt, self.doc["plan"].get("renames", {}), self.model.comps,
                                self.doc["fingerprint"])
        return self._names

    def say(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    def warn(self, text: str) -> None:
        print(text, file=self.err, flush=True)
