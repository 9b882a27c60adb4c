"""Files → `System`: reading (UTF-8 only), includes (relative to the including file,
cycles refused), merging every file's items, then name resolution.

What is read is bounded by what is read, not by what a file says it is: regular files only
(standard input as `-`), at most `MAX_FILE_BYTES` a file and `MAX_TOTAL_BYTES` for all the
files of one load; includes stay in the directory tree of the file named on the command line
unless `allow_includes_outside` is set, and nest at most `MAX_INCLUDE_DEPTH` deep. Includes
are followed by a loop over an explicit stack, so no input can make the loader recurse."""
from __future__ import annotations

import os
import stat
import sys
from dataclasses import dataclass, field
from typing import Callable, Optional

from . import ir
from .diagnostics import Diagnostic, DiagnosticError, Related, error
from .gcpause import gc_paused
from .parser import parse_text
from .resolve import resolve
from .span import Span

MAX_FILE_BYTES = 64 * 1024 * 1024    # one file (RC010)
MAX_TOTAL_BYTES = 128 * 1024 * 1024  # every file of one load, includes included (RC015)
MAX_INCLUDE_DEPTH = 32               # includes of includes (RC017)
STDIN = "-"                          # the path that reads standard input
STDIN_NAME = "<stdin>"               # how standard input is shown in diagnostics
ALLOW_OUTSIDE_ENV = "RECONF_ALLOW_INCLUDES_OUTSIDE"

_CHUNK = 16 * 1024 * 1024


@dataclass
class Settings:
    """How loading is allowed to go; `reconf --allow-includes-outside` sets `allow_includes_outside`."""

    allow_includes_outside: bool = False


settings = Settings()

_TRUE = ("1", "true", "t", "yes", "y", "on")   # what click reads as true in the same variable


def includes_outside_allowed() -> bool:
    """`settings`, or RECONF_ALLOW_INCLUDES_OUTSIDE in the environment (for every entry point)."""
    return settings.allow_includes_outside or os.environ.get(ALLOW_OUTSIDE_ENV, "").strip().lower() in _TRUE


@dataclass
class Sources:
    """The text of every file read, for caret snippets."""

    texts: dict[str, str] = field(default_factory=dict)
    _lines: dict[str, tuple[str, list[str]]] = field(default_factory=dict, repr=False, compare=False)

    def line(self, file: str, line: int) -> Optional[str]:
        text = self.texts.get(file)
        if text is None:
            return None
        kept = self._lines.get(file)
        if kept is None or kept[0] is not text:       # split once per text: a report asks once per diagnostic
            kept = self._lines[file] = (text, text.split("\n"))
        lines = kept[1]
        return lines[line - 1] if 0 < line <= len(lines) else None


@dataclass
class Budget:
    """The bytes the files of one load may still take together."""

    remaining: int = MAX_TOTAL_BYTES


def display_path(path: str) -> str:
    if path == STDIN:
        return STDIN_NAME
    rel = os.path.relpath(path)
    return path if rel.startswith("..") else rel


_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def _refuse_unless_regular(mode: int, shown: str, where: Span, code: str) -> None:
    """A directory keeps the not-found code; a device, FIFO or socket is RC014."""
    if stat.S_ISREG(mode):
        return
    if stat.S_ISDIR(mode):
        raise DiagnosticError([error(code, f"{shown} is a directory, not an .arch file", where)])
    kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
    raise DiagnosticError([error("RC014", f"{shown} is {kind}, not a regular file; it is not read", where,
                                 notes=("architectures are read from regular files, or from standard input "
                                        "as `-`",))])


def _too_large(shown: str, size: Optional[int], limit: int, where: Span) -> DiagnosticError:
    """RC010 when the file is over the limit of one file, RC015 when it is over what the load has left."""
    if limit >= MAX_FILE_BYTES or (size is not None and size > MAX_FILE_BYTES):
        what = f"is {size} bytes" if size is not None else "holds more"
        return DiagnosticError([error("RC010", f"{shown} {what}; the limit is {MAX_FILE_BYTES} bytes (64 MiB)",
                                      where)])
    return DiagnosticError([error("RC015", f"{shown} is not read: the files of one system may take "
                                           f"{MAX_TOTAL_BYTES} bytes together, and {limit} are left", where)])


def _read_fd(fd: int, most: int) -> bytes:
    """At most `most` bytes, whatever the file claims to hold."""
    chunks: list[bytes] = []
    left = most
    while left > 0:
        chunk = os.read(fd, min(left, _CHUNK))
        if not chunk:
            break
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def _read_file(path: str, shown: str, where: Span, code: str, limit: int) -> bytes:
    try:
        _refuse_unless_regular(os.stat(path).st_mode, shown, where, code)   # a device is not even opened
        # O_NONBLOCK: a FIFO put in the file's place since the stat must not block the open
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))
        try:
            st = os.fstat(fd)                       # what was opened, not what the path named a moment ago
            _refuse_unless_regular(st.st_mode, shown, where, code)
            if st.st_size > limit:
                raise _too_large(shown, st.st_size, limit, where)
            data = _read_fd(fd, limit + 1)          # the file may have grown since the fstat
        finally:
            os.close(fd)
    except FileNotFoundError:
        raise DiagnosticError([error(code, f"no such file: {shown}", where)]) from None
    except IsADirectoryError:
        raise DiagnosticError([error(code, f"{shown} is a directory, not an .arch file", where)]) from None
    except OSError as e:
        raise DiagnosticError([error(code, f"cannot read {shown}: {e.strerror}", where)]) from None
    if len(data) > limit:
        raise _too_large(shown, None, limit, where)
    return data


def _read_stdin(where: Span, code: str, limit: int) -> bytes:
    stream = getattr(sys.stdin, "buffer", None)
    if stream is None:
        raise DiagnosticError([error(code, "there is no standard input to read", where)])
    try:
        data: bytes = stream.read(limit + 1)
    except OSError as e:
        raise DiagnosticError([error(code, f"cannot read {STDIN_NAME}: {e.strerror}", where)]) from None
    if len(data) > limit:
        raise _too_large(STDIN_NAME, None, limit, where)
    return data


def read_source(path: str, sources: Sources, at: Optional[Span] = None, budget: Optional[Budget] = None) -> str:
    """Read one file (or standard input, as `-`) as UTF-8; every failure becomes a diagnostic.

    A file that is refused is not read, and nothing of it is kept in `sources`."""
    shown = display_path(path)
    where = at or Span(shown, 1, 1, 1, 1)
    code = "RC008" if at is not None else "RC007"
    limit = MAX_FILE_BYTES if budget is None else min(MAX_FILE_BYTES, budget.remaining)
    data = _read_stdin(where, code, limit) if path == STDIN else _read_file(path, shown, where, code, limit)
    if budget is not None:
        budget.remaining -= len(data)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        good = data[: e.start].decode("utf-8", "replace")
        line = good.count("\n") + 1
        col = len(good) - (good.rfind("\n") + 1) + 1
        raise DiagnosticError([error("RC005", f"{shown} is not UTF-8 text (byte 0x{data[e.start]:02x})",
                                     Span(shown, line, col, line, col + 1),
                                     notes=("save the file as UTF-8",))]) from None
    if text.startswith("\ufeff"):
        text = text[1:]
    sources.texts[shown] = text
    return text


@dataclass(frozen=True)
class _Visit:
    """A file to read: the path to open, the files that include it (each file's real path and its
    include statement), the include statement naming it, and the top-level file whose directory
    tree its includes stay in."""

    path: str
    chain: tuple[tuple[str, Span], ...]
    at: Optional[Span]
    top: str
    root: str


def _real(path: str) -> str:
    return STDIN_NAME if path == STDIN else os.path.realpath(path)


def _root(path: str) -> str:
    """The directory tree a top-level file's includes must stay in (the current one for stdin)."""
    return os.path.realpath(os.getcwd() if path == STDIN else os.path.dirname(os.path.abspath(path)))


def _inside(real: str, root: str) -> bool:
    return real == root or os.path.commonpath([real, root]) == root


def _outside(v: _Visit, real: str, at: Span) -> Diagnostic:
    where = display_path(v.path)
    resolved = display_path(real)
    also = f" (it resolves to {resolved})" if resolved != where else ""
    tree = display_path(v.root)
    tree = tree if tree.endswith(os.sep) else tree + os.sep
    whose = ("the current directory, where the includes of standard input are found" if v.top == STDIN
             else f"the directory of {display_path(v.top)} (named on the command line)")
    return error("RC016", f"include of {where}{also} refused: it is outside {tree}, {whose}", at,
                 notes=("includes stay in the directory tree of the file named on the command line; "
                        f"`reconf --allow-includes-outside` (or {ALLOW_OUTSIDE_ENV}=1) allows others",))


Reader = Callable[[str, Sources, Optional[Span], Budget], str]
"""How a file's text is had: `read_source`, or an editor's text of the files it has open."""
ParseFn = Callable[[str, str], ir.Document]


def load_documents(paths: list[str], sources: Sources, *, allow_outside: Optional[bool] = None,
                   reader: Reader = read_source, parse: ParseFn = parse_text) -> list[ir.Document]:
    """Parse the given files and everything they include, each file once, in the order a
    depth-first walk meets them. `reader` reads a file as `read_source` does (an editor gives
    the text it has), `parse` parses it as `parse_text` does (an editor keeps what it parsed)."""
    allow = includes_outside_allowed() if allow_outside is None else allow_outside
    docs: list[ir.Document] = []
    seen: set[str] = set()
    errors: list[Diagnostic] = []
    budget = Budget(MAX_TOTAL_BYTES)
    todo = [_Visit(p, (), None, p, _root(p)) for p in reversed(paths)]
    while todo:
        v = todo.pop()
        real, at = _real(v.path), v.at
        if at is not None:
            if not allow and not _inside(real, v.root):
                errors.append(_outside(v, real, at))
                continue
            if any(real == s for s, _ in v.chain):
                chain = [display_path(s) for s, _ in v.chain] + [display_path(real)]
                errors.append(error("RC009", "include cycle: " + " → ".join(chain), at,
                                    related=tuple(Related(sp, "included here") for _, sp in v.chain[1:])))
                continue
            if len(v.chain) > MAX_INCLUDE_DEPTH:
                errors.append(error("RC017", f"includes nest more than {MAX_INCLUDE_DEPTH} deep: "
                                             f"{display_path(v.path)} is not read", at,
                                    related=(Related(v.chain[0][1], "the chain of includes starts here"),),
                                    notes=(f"a file may be included through at most {MAX_INCLUDE_DEPTH} "
                                           "others",)))
                continue
        if real in seen:
            continue
        seen.add(real)
        shown = display_path(v.path)
        try:
            text = reader(v.path, sources, at, budget)
            if not text.strip() and at is None:
                raise DiagnosticError([error("RC006", f"{shown} is empty: nothing to check",
                                             Span(shown, 1, 1, 1, 1),
                                             notes=("an architecture starts with `system NAME`",))])
            doc = parse(text, shown)
        except DiagnosticError as e:
            errors.extend(e.diagnostics)
            continue
        docs.append(doc)
        base = "" if v.path == STDIN else os.path.dirname(v.path)
        includes = [item for item in doc.items if isinstance(item, ir.Include)]
        for item in reversed(includes):    # popped in the order they are written
            todo.append(_Visit(os.path.join(base, item.path), v.chain + ((real, item.span),), item.span,
                               v.top, v.root))
    if errors:
        raise DiagnosticError(errors)
    return docs


def load(paths: list[str], sources: Optional[Sources] = None, *, allow_outside: Optional[bool] = None,
         parse: ParseFn = parse_text) -> ir.System:
    """Read, parse, merge and resolve. Raises DiagnosticError with every error found.

    `allow_outside` lets includes leave the directory tree of the file named (default:
    `includes_outside_allowed()`); `parse` parses one file (a warm analyzer's keeps what it read)."""
    sources = sources if sources is not None else Sources()
    with gc_paused():
        return resolve(load_documents(paths, sources, allow_outside=allow_outside, parse=parse))


def load_text(text: str, file: str = "<input>", sources: Optional[Sources] = None) -> ir.System:
    """Parse and resolve one in-memory file (includes are not allowed here)."""
    if sources is not None:
        sources.texts[file] = text
    with gc_paused():
        return resolve([parse_text(text, file)])
