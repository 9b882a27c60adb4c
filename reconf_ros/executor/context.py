"""What one run of a plan carries from step to step: the plan, its model and states, the
script's options, the ROS runtime, the components' nodes, the processes the run started, and
where its words go."""
from __future__ import annotations

import argparse
import datetime
import os
import signal
import threading
from dataclasses import dataclass, field
from typing import Any, Callable, Optional, Protocol

from .naming import Names
from .plan_states import PlanStates
from .remote import Hosts
from .semantics import Model
from .steps import Step, batches, plan_steps


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
    proc: Any                        # its subprocess.Popen, the launcher's handle, or an agent's RemoteProcess
    ended: Optional[int] = None      # its exit status, once a remove has waited for it
    host: str = ""                   # the host whose agent started it ("": this machine; its pid and log are there)
    held: Optional[float] = None     # s it was held before its step, if forked ahead (docs/executor.md#held)
    how: str = ""                    # how it was started, for the step's line

    def to_doc(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"pid": self.pid, "log": self.log, "command": self.command, "node": self.node}
        doc.update({"host": self.host} if self.host else {})
        doc.update({"held_s": round(self.held, 3)} if self.held is not None else {})
        return doc if self.ended is None else {**doc, "ended": self.ended}


@dataclass
class Held:
    """A node process forked ahead of its create and held before it makes its node
    (docs/executor.md#held)."""
    proc: Any                        # the launcher's handle
    argv: list[str]
    log: str
    at: float                        # when it was forked (monotonic)


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


class Interrupts:
    """SIGINT and SIGTERM as a run takes them (docs/executor.md#interrupted): the first asks the
    run to stop at the end of the current step, the second (and any later one) stops it at once
    (KeyboardInterrupt, where Python is when it comes). A manager also counts the stop requests
    its client forwards (`poll`: a call that returns who asked, or "")."""

    def __init__(self) -> None:
        self.count = 0                 # stops asked: signals and forwarded requests
        self.signals = 0               # signals this process received
        self.by = ""                   # who asked first
        self.poll: Optional[Callable[[], str]] = None

    def handler(self, signum: int, frame: Any) -> None:
        self.signals += 1
        self.ask(signal.Signals(signum).name)
        if self.count > 1:
            raise KeyboardInterrupt

    def ask(self, by: str) -> None:
        self.count += 1
        self.by = self.by or by

    def install(self) -> None:
        """Take SIGINT and SIGTERM (in the main thread)."""
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self.handler)

    def forget_requests(self) -> None:
        """After a manager's run: only this process's own signals still count."""
        self.count, self.poll = self.signals, None
        self.by = self.by if self.signals else ""

    @property
    def stop(self) -> bool:
        asked = self.poll() if self.poll is not None else ""
        if asked:
            self.ask(asked)
        return self.count > 0


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
    interrupts: Interrupts = field(default_factory=Interrupts)
    step: int = 0                    # the step being performed (0: none yet)
    began: float = 0.0               # when it began, on the wall clock (what the nodes' statuses use)
    baseline: dict[str, int] = field(default_factory=dict)    # each counted monitor's violations at its start
    violated: dict[str, int] = field(default_factory=dict)    # a monitor whose count moved -> the step it was seen after
    violations: dict[str, int] = field(default_factory=dict)  # such a monitor -> how many it saw, at the last count
    last_violation: dict[str, str] = field(default_factory=dict)  # such a monitor -> its status's `last_violation`
    unread: set[str] = field(default_factory=set)     # components whose node did not answer the last reading
    read_at: Optional[float] = None  # when the last reading of the nodes began, on the wall clock
    failed_host: str = ""            # the host whose agent failed the last step (docs/hosts.md)
    # removed components this run saw end: finalized at their remove, or their process exited;
    # absent from then on, and not asked again (a finalized node cannot come back)
    ended: set[str] = field(default_factory=set)
    gaps: dict[str, float] = field(default_factory=dict)   # "comp.port" -> its largest input gap before the first step
    held: dict[str, Held] = field(default_factory=dict)    # component -> its process, forked ahead and held
    holding: Any = None              # the thread that forks them (`processes.hold`), while it runs
    hold_stop: threading.Event = field(default_factory=threading.Event)     # it stops forking

    def __post_init__(self) -> None:
        self.model = Model(self.doc["model"])
        self.steps: list[Step] = plan_steps(self.doc)
        # steps performed together; one at a time with --one-at-a-time (docs/executor.md#batches)
        self.batches: list[tuple[int, int]] = [] if getattr(self.args, "one_at_a_time", False) else batches(self.doc)
        self.states = PlanStates(self.doc["plan"])
        self.runs: dict[str, Optional[str]] = {c["name"]: c.get("run") for c in self.doc["model"]["components"]}
        self.log_dir: str = self.args.log_dir or os.path.join(
            "reconf-logs", f"{self.doc['system']}-{datetime.datetime.now().strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")
        self._names: Optional[Names] = None
        recovery = self.doc["plan"].get("recovery") or {}
        self.placed: dict[str, str] = dict(recovery.get("placed") or {})
        self.orphans: list[dict[str, Any]] = list(recovery.get("orphans") or [])
        hosts_file = getattr(self.args, "hosts", "")
        # the agents of the hosts file (--hosts): each reached on first use
        self.hosts: Optional[Hosts] = Hosts(hosts_file, self.args.timeout) if hosts_file else None

    @property
    def names(self) -> Names:
        """The components' nodes (made with the runtime, which knows the namespace and the graph)."""
        if self._names is None:
            self._names = Names(self.rt, self.doc["plan"].get("renames", {}), self.model.comps,
                                self.doc["fingerprint"])
            self._names.placed.update(self.placed)     # where a recovery found the nodes
        return self._names

    def say(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    def warn(self, text: str) -> None:
        print(text, file=self.err, flush=True)
