"""A topic's observed rate: the worst of its sliding windows, computed as its log times stream
by, keeping only the current window's (docs/recordings.md#the-observed-rate)."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Optional

__all__ = ["NS", "Worst", "RateMeter"]

NS = 1_000_000_000


@dataclass(frozen=True)
class Worst:
    """A topic's worst window: its rate (Hz) and start (s from the recording's start); `gap` when
    it held no message after its start (the silence, s, whose inverse is the rate), `to_end` when
    the silence ran to the recording's end."""

    hz: float
    at: float
    gap: Optional[float] = None
    to_end: bool = False


class RateMeter:
    """One topic's worst window, fed its log times in order.

    A window starts at each message, and at `start_ns` when the recorder stated when it started
    (`opened`; otherwise t counts from `start_ns` but the topic's first window is at its own first
    message); it spans `window_ns`. Its rate is the number of message intervals in it over their
    time; when no message follows its start within it, one over the silence: up to the next
    message, or up to the recording's end. A window that would end after the recording is not
    judged."""

    def __init__(self, window_ns: int, start_ns: int, opened: bool = False) -> None:
        self.window, self.start = window_ns, start_ns
        self.anchors: deque[tuple[int, int]] = deque([(start_ns, 0)] if opened else [])   # (start, messages up to it)
        self.n = 0
        self.last = start_ns
        self.worst: Optional[Worst] = None

    def feed(self, t: int) -> None:
        t = max(t, self.last)          # storage files that overlap by a hair: never a negative interval
        while self.anchors and t - self.anchors[0][0] > self.window:
            a, i = self.anchors.popleft()
            self._judge(a, i, t)
        if self.n == 0 and self.anchors and self.anchors[0][0] == t:
            self.anchors.popleft()     # the topic's first message opens the recording: one window, not two
        self.n += 1
        self.last = t
        self.anchors.append((t, self.n))

    def finish(self, end_ns: int) -> Optional[Worst]:
        """The worst window, once the recording's end is known; None when no window fits in it."""
        for a, i in self.anchors:
            if end_ns - a >= self.window:
                self._judge(a, i, None, end_ns)
        self.anchors.clear()
        return self.worst

    def _judge(self, a: int, i: int, next_t: Optional[int], end: int = 0) -> None:
        at = (a - self.start) / NS
        if self.n > i and self.last == a:
            return                     # messages logged at one instant: no interval to measure
        if self.n > i:
            w = Worst((self.n - i) * NS / (self.last - a), at)
        elif next_t is not None:
            w = Worst(NS / (next_t - a), at, gap=(next_t - a) / NS)
        else:
            w = Worst(NS / (end - a), at, gap=(end - a) / NS, to_end=True)    # as the start's silence
        if self.worst is None or w.hz < self.worst.hz:
            self.worst = w
