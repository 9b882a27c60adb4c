"""The assumption monitor: what each input receives on the wire, judged against the model.

Pure Python (no ROS): the node feeds it arrivals and asks it, on a timer, which
functionalities' assumptions are met. docs/runtime.md states the rule:

  an input assumption `T @ r` is met at time t when a message of type T arrived on an
  associated input in (t - k/r, t], with k the gap factor (1.5 by default); a rate-less
  assumption is met while a publisher is matched or a message has arrived; an assumption no
  associated input can satisfy comes from the environment and is not observed.

A *violation* is a stretch of time in which a functionality is in its normal mode and one of
its observed assumptions is not met: the safety property of docs/design.md#the-semantic-model,
on the wire.

Times are the middleware's: an arrival is timed by its reception timestamp, so a node that is
itself slow to run its callbacks does not mistake its own delay for a gap on the wire. A gap is
judged exactly when the message that ends it arrives; a silence is judged by a timer, which
allows itself `grace` before it calls a gap a violation. A timer's verdict is provisional: the
timer may run while a message that arrived in time still waits for its callback, so when the
next arrival shows the input was within its limit, the provisional violation is withdrawn. A
gap is never lost this way: the arrival that ends it judges it exactly.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Optional

from .api import Component, Functionality, Input, Predicate

__all__ = ["Monitor", "SourceStats", "InputStats", "GAP_FACTOR"]

GAP_FACTOR = 1.5
RATE_WINDOW = 1.0   # seconds over which the measured rate is given


@dataclass
class SourceStats:
    """One publisher (by DDS GID) as seen by one input."""

    node: str = "?"
    received: int = 0
    last_seq: int = 0
    lost: int = 0          # gaps in the publisher's sequence numbers
    missed_head: int = 0   # messages it published before this input received its first
    last: float = 0.0


@dataclass
class InputStats:
    port: Input
    sources: dict[bytes, SourceStats] = field(default_factory=dict)
    last: Optional[float] = None
    received: int = 0
    window: deque[float] = field(default_factory=deque)
    max_gap: float = 0.0             # largest wait while a normal functionality relied on it, judged exactly
    open_gap: float = 0.0            # the wait a timer saw since the last arrival (provisional, as its violations)
    needed_since: Optional[float] = None
    publishers: dict[str, int] = field(default_factory=dict)   # connector -> matched publishers
    owed: deque[float] = field(default_factory=deque)   # on-demand input: when each owed message was asked

    def waited(self, now: float) -> float:
        """How long a normal functionality relying on this input has waited for a message."""
        assert self.needed_since is not None
        return max(0.0, now - (self.needed_since if self.last is None else max(self.last, self.needed_since)))

    def owed_since(self) -> float:
        """Since when an on-demand input has waited: its oldest owed message's asking, or its
        last answer if later (a rate while asked: a burst of asks answered one by one at the
        rate meets it; the latency of each ask is the asker's to judge)."""
        return self.owed[0] if self.last is None else max(self.owed[0], self.last)

    def period_limit(self, factor: float) -> Optional[float]:
        hz = self.port.assumption.hz
        return None if hz is None else factor / float(hz)


class Monitor:
    """Per-input arrival statistics and per-functionality wire verdicts of one component."""

    def __init__(self, component: Component, gap_factor: float = GAP_FACTOR) -> None:
        self.component, self.factor = component, gap_factor
        self.inputs = {p.name: InputStats(p) for p in component.inputs}
        self.verdicts: dict[str, str] = {f.name: "unobserved" for f in component.functionalities}
        self.violating: dict[str, float] = {}        # functionality -> since when
        self.violations = 0
        self.violation_seconds = 0.0
        self.history: list[tuple[float, str, str]] = []   # (t, functionality, reason) of each violation
        self.provisional: set[str] = set()     # violations only a timer has seen so far

    # --- arrivals ---
    def expect(self, port: str, now: float) -> None:
        """An on-demand input is owed one more message, asked for at `now`."""
        self.inputs[port].owed.append(now)

    def give_up(self, port: str) -> None:
        """The oldest message owed on an on-demand input will not come (its asker gave the
        request up, as an FTM protocol does after GIVE_UP_AFTER): it is no longer waited for."""
        st = self.inputs[port]
        if st.owed:
            st.owed.popleft()

    def duplicate(self, port: str, gid: bytes, seq: Optional[int]) -> bool:
        """Whether the message `seq` of publisher `gid` on `port` was taken already (two readers of
        one input both deliver a transient-local publisher's data)."""
        src = self.inputs[port].sources.get(gid)
        return seq is not None and src is not None and seq <= src.last_seq

    def on_message(self, port: str, now: float, gid: bytes, seq: Optional[int], node: str = "?") -> None:
        st = self.inputs[port]
        if st.port.on_demand:
            if st.owed:
                waited = now - st.owed_since()
                st.owed.popleft()
                if st.needed_since is not None:
                    st.max_gap = max(st.max_gap, waited)
        elif st.needed_since is not None:
            st.max_gap = max(st.max_gap, st.waited(now))
        st.open_gap = 0.0                  # the arrival judged the wait exactly
        now = max(now, st.last or now)     # reception order, in case timestamps disagree by a hair
        st.last, st.received = now, st.received + 1
        st.window.append(now)
        while st.window and st.window[0] < now - RATE_WINDOW:
            st.window.popleft()
        src = st.sources.get(gid)
        if src is None:
            src = st.sources[gid] = SourceStats(node=node)
            if seq is not None and seq > 1:
                src.missed_head = seq - 1
        elif src.node == "?":
            src.node = node     # data can come before discovery names its publisher's node
        elif seq is not None and seq > src.last_seq + 1:
            src.lost += seq - src.last_seq - 1
        if seq is not None:
            src.last_seq = max(src.last_seq, seq)
        src.received, src.last = src.received + 1, now

    def rate(self, port: str, now: float) -> float:
        st = self.inputs[port]
        return sum(1 for t in st.window if t > now - RATE_WINDOW) / RATE_WINDOW

    def fresh_sources(self, port: str, now: float) -> list[str]:
        """Nodes this input heard from within its assumption's gap limit (any time, if rate-less)."""
        st = self.inputs[port]
        limit = st.period_limit(self.factor)
        return sorted({s.node for s in st.sources.values() if limit is None or now - s.last <= limit})

    # --- verdicts ---
    def _observers(self, f: Functionality, a: Predicate) -> list[InputStats]:
        return [self.inputs[i.name] for i in f.inputs if i.assumption.satisfies(a)]

    def judge(self, f: Functionality, now: float, attached: dict[str, list[str]], grace: float = 0.0) -> str:
        """"met", "unobserved" (only environment assumptions) or "not met: why", for f's normal mode."""
        observed = False
        for a in f.normal.assumes:
            watchers = self._observers(f, a)
            if not watchers:
                continue
            observed = True
            why = []
            for st in watchers:
                name = st.port.name
                if not attached.get(name):
                    why.append(f"{name} is attached to nothing")
                    continue
                if a.hz is None:
                    if st.received or any(st.publishers.get(k, 0) for k in attached[name]):
                        break
                    why.append(f"{name} has no publisher")
                    continue
                limit = self.factor / float(a.hz)
                if st.port.on_demand:   # owed its rate only while something is asked
                    if not st.received and not any(st.publishers.get(k, 0) for k in attached[name]):
                        why.append(f"{name} has no publisher")
                        continue
                    if not st.owed or now - st.owed_since() <= limit + grace:
                        break
                    why.append(f"{name}: asked and waiting {now - st.owed_since():.3f} s for an answer (limit "
                               f"{limit:.3f} s for {a})")
                    continue
                if st.last is not None and now - st.last <= limit + grace:
                    break
                age = "nothing received" if st.last is None else f"last message {now - st.last:.3f} s ago"
                why.append(f"{name}: {age} (limit {limit:.3f} s for {a})")
            else:
                return "not met: " + "; ".join(why)
        return "met" if observed else "unobserved"

    def check(self, now: float, modes: dict[str, str], attached: dict[str, list[str]], grace: float = 0.0) -> bool:
        """Update every verdict and violation at `now`; True when something a status shows changed.
        A timer passes its `grace` (> 0) and its violations are provisional; an arrival passes 0."""
        changed = False
        exact = grace == 0.0
        needed: set[str] = set()
        for f in self.component.functionalities:
            verdict = self.judge(f, now, attached, grace)
            if verdict.split(":")[0] != self.verdicts[f.name].split(":")[0]:
                changed = True
            self.verdicts[f.name] = verdict
            normal = modes.get(f.name) == "normal"
            if normal:
                needed |= {st.port.name for a in f.normal.assumes for st in self._observers(f, a)}
            bad = normal and verdict.startswith("not met")
            if bad and f.name not in self.violating:
                self.violating[f.name] = now
                self.violations += 1
                self.history.append((now, f.name, verdict))
                if not exact:
                    self.provisional.add(f.name)
                changed = True
            elif bad and exact:
                self.provisional.discard(f.name)       # an arrival confirms it
            elif not bad and f.name in self.violating:
                since = self.violating.pop(f.name)
                if exact and f.name in self.provisional:   # the timer ran ahead of a message on time
                    self.violations -= 1
                    self.history = [h for h in self.history if not (h[0] == since and h[1] == f.name)]
                else:
                    self.violation_seconds += max(0.0, now - since)
                self.provisional.discard(f.name)
                changed = True
        for name, st in self.inputs.items():
            if name in needed:
                if st.needed_since is None:
                    st.needed_since = now
                # a timer's look (grace > 0) may run while a message that came in time waits for its
                # callback: it stays open until the next arrival judges the wait, as its violation does
                wait = st.waited(now) if not st.port.on_demand else now - st.owed_since() if st.owed else 0.0
                if exact:
                    st.max_gap = max(st.max_gap, wait)
                else:
                    st.open_gap = max(st.open_gap, wait)
            else:
                st.needed_since = None
        return changed

    def status(self, now: float) -> dict[str, str]:
        """The monitor's part of the component's status (docs/control-interface.md#status-on-diagnostics)."""
        out = {"violations": str(self.violations),
               "violation_s": f"{self.violation_seconds + sum(now - t for t in self.violating.values()):.3f}"}
        if self.history:
            t, f, why = self.history[-1]
            out["last_violation"] = f"{t:.3f} {f}: {why}"
        for f, v in self.verdicts.items():
            out[f"wire.{f}"] = v
        for name, st in self.inputs.items():
            out[f"in.{name}.received"] = str(st.received)
            out[f"in.{name}.lost"] = str(sum(s.lost for s in st.sources.values()))
            out[f"in.{name}.missed_head"] = str(sum(s.missed_head for s in st.sources.values()))
            out[f"in.{name}.max_gap_s"] = f"{max(st.max_gap, st.open_gap):.3f}"
            out[f"in.{name}.rate_hz"] = f"{self.rate(name, now):.2f}"
            out[f"in.{name}.age_s"] = "" if st.last is None else f"{now - st.last:.3f}"
            out[f"in.{name}.fresh"] = ",".join(self.fresh_sources(name, now))
            if st.port.on_demand:
                out[f"in.{name}.on_demand"] = "1"
            for src in st.sources.values():
                out[f"in.{name}.from.{src.node}"] = f"{src.received}/{src.lost}/{src.missed_head}"
                out[f"in.{name}.last.{src.node}"] = f"{src.last:.3f}"
            for k, n in sorted(st.publishers.items()):
                out[f"in.{name}@{k}.publishers"] = str(n)
        return out
