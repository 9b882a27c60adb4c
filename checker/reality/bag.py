"""A rosbag2 recording read for its timestamps only (docs/recordings.md).

A recording is a directory with metadata.yaml, or a single `.db3` (sqlite3) or `.mcap` file,
read through `rosbags` (pure Python, no ROS). Message bodies are never deserialized: what is
kept is each topic's name and recorded type(s), and a stream of (topic, log time) pairs in
time order, read as the storage streams it, so memory does not grow with the recording. When
the recorder wrote when it started and stopped (reconf_ros.tools.record does, in metadata.yaml's
custom_data), those bound the recording instead of its first and last messages."""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, Optional

__all__ = ["Recording", "RecordedTopic", "Unreadable", "open_recording", "STARTED", "STOPPED"]

STARTED, STOPPED = "reconf.record.started_ns", "reconf.record.stopped_ns"    # custom_data keys, ns since the epoch


class Unreadable(Exception):
    """The recording cannot be read: missing, not a rosbag2 recording, or corrupt."""


@dataclass(frozen=True)
class RecordedTopic:
    name: str
    types: tuple[str, ...]      # one, unless the topic was recorded with several types
    count: int                  # messages, as the recording's index says


@dataclass
class Recording:
    path: str
    storage: str                # sqlite3 | mcap
    topics: dict[str, RecordedTopic]
    start: int                  # ns, the earliest message's log time
    end: int                    # ns, the latest message's log time
    messages: int
    _reader: Any = None
    bounds: Optional[tuple[int, int]] = None   # ns, when the recorder started and stopped, if it said

    @property
    def opened(self) -> int:
        """Where the recording starts (ns): the recorder's start, else the first message."""
        return self.bounds[0] if self.bounds else self.start

    @property
    def closed(self) -> int:
        """Where the recording ends (ns): the recorder's stop, else the last message."""
        return self.bounds[1] if self.bounds else self.end

    def stamps(self, topics: Iterable[str]) -> Iterator[tuple[str, int]]:
        """(topic, log time in ns) of every message on `topics`, in time order; the bodies are not
        decoded (and other topics' not read)."""
        wanted = set(topics)
        conns = [c for c in self._reader.connections if c.topic in wanted]
        if not conns:
            return
        try:
            for conn, stamp, _ in self._reader.messages(conns):
                yield conn.topic, stamp
        except Exception as e:    # a corrupt page or chunk, found only when it is read
            raise Unreadable(_why(e)) from None


def _why(e: BaseException) -> str:
    text = str(e).strip() or type(e).__name__
    return text if type(e).__name__ in ("ReaderError", "FileNotFoundError") else f"{type(e).__name__}: {text}"


def _storage(path: Path) -> str:
    if path.is_dir():
        return "mcap" if any(path.glob("*.mcap")) else "sqlite3"
    return "mcap" if path.suffix == ".mcap" else "sqlite3"


def _bounds(reader: Any, start: int, end: int, n: int) -> Optional[tuple[int, int]]:
    """The recorder's start and stop from custom_data, widened to hold every message; None when
    it did not say (or said it in a form that is not two times in ns)."""
    custom = getattr(getattr(reader, "storage", None), "metadata", None)
    custom = getattr(custom, "custom", None) or {}
    try:
        began, stopped = int(custom[STARTED]), int(custom[STOPPED])
    except (KeyError, TypeError, ValueError):
        return None
    return (min(began, start), max(stopped, end)) if n else (began, max(began, stopped))


@contextmanager
def open_recording(path: str) -> Iterator[Recording]:
    """The recording at `path`, open while the block runs; `Unreadable` when it cannot be read."""
    p = Path(path)
    if not p.exists():
        raise Unreadable("no such file or directory")
    if not p.is_dir() and p.suffix not in (".db3", ".mcap"):
        raise Unreadable("not a rosbag2 recording: give its directory (with metadata.yaml), a .db3 or an .mcap file")
    try:
        from rosbags.rosbag2 import Reader
    except ImportError:   # pragma: no cover - a main dependency
        raise Unreadable("the `rosbags` package is not installed (pip install rosbags)") from None
    try:
        reader = Reader(p)
        reader.open()
    except Exception as e:
        raise Unreadable(_why(e)) from None
    try:
        topics = {name: RecordedTopic(name, tuple(sorted({c.msgtype for c in info.connections})), info.msgcount)
                  for name, info in reader.topics.items()}
        n = reader.message_count
        start, end = (reader.start_time, reader.end_time - 1) if n else (0, 0)
        yield Recording(str(p), _storage(p), topics, start, end, n, reader, _bounds(reader, start, end, n))
    finally:
        try:
            reader.close()
        except Exception:
            pass
