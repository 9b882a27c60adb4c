"""Architectures and policies read from git revisions: `git:REF:PATH`, read from the repository
of the working directory without checking it out (PATH from the repository root, or from here
when it starts `./` or `../`): only the named file and the files it includes, transitively, are
read from the revision (`git cat-file --batch`), never the whole tree."""
from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field, replace
from typing import IO, Iterator, Optional

from reconf_dsl import ir
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, error
from reconf_dsl.loader import MAX_FILE_BYTES, Sources, display_path
from reconf_dsl.parser import parse_text
from reconf_dsl.span import Span

GIT_PREFIX = "git:"


class _CatFile:
    """One `git cat-file --batch --follow-symlinks` process: objects by name, one at a time."""

    def __init__(self, top: str) -> None:
        self.aborted = False
        try:
            self.proc = subprocess.Popen(["git", "cat-file", "--batch", "--follow-symlinks"], cwd=top,
                                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        except FileNotFoundError:
            raise DiagnosticError([error("RC506", "cannot read from git: git is not installed",
                                         Span.unknown("<git>"))]) from None

    def blob(self, name: str, limit: int) -> tuple[str, Optional[bytes], int]:
        """(kind, content, size) of the object `name`: kind "blob" with its content when it is a
        file of at most `limit` bytes, "missing" when there is none, else its kind and no content."""
        stdin, stdout = self.proc.stdin, self.proc.stdout
        assert stdin is not None and stdout is not None
        try:
            stdin.write(name.encode("utf-8") + b"\n")
            stdin.flush()
            header = stdout.readline()
        except (BrokenPipeError, OSError):
            header = b""
        if not header:
            raise DiagnosticError([error("RC506", f"cannot read {name}: git cat-file stopped",
                                         Span.unknown("<git>"))])
        parts = header.split()
        if len(parts) == 3 and parts[2].isdigit() and parts[1] in (b"blob", b"tree", b"commit", b"tag"):
            kind, size = parts[1].decode(), int(parts[2])
            if kind == "blob" and size > limit:
                self.abort()            # not read through: the process is stopped instead
                return "large", None, size
            if kind != "blob":
                self._skip(stdout, size + 1)
                return kind, None, size
            data = self._exactly(stdout, size)
            self._skip(stdout, 1)
            return "blob", data, size
        if len(parts) == 2 and parts[1].isdigit() and parts[0] in (b"symlink", b"dangling", b"loop", b"notdir"):
            self._skip(stdout, int(parts[1]) + 1)
            return parts[0].decode(), None, 0
        return "missing", None, 0

    @staticmethod
    def _exactly(stream: IO[bytes], n: int) -> bytes:
        chunks, left = [], n
        while left:
            chunk = stream.read(min(left, 1 << 20))
            if not chunk:
                raise DiagnosticError([error("RC506", "git cat-file stopped in the middle of a file",
                                             Span.unknown("<git>"))])
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)

    @staticmethod
    def _skip(stream: IO[bytes], n: int) -> None:
        while n > 0:
            chunk = stream.read(min(n, 1 << 20))
            if not chunk:
                return
            n -= len(chunk)

    def abort(self) -> None:
        self.proc.kill()
        self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream:
                with contextlib.suppress(OSError):
                    stream.close()
        self.aborted = True

    def close(self) -> None:
        if self.aborted:
            return
        if self.proc.stdin:
            with contextlib.suppress(OSError):
                self.proc.stdin.close()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.proc.stdout:
            self.proc.stdout.close()


@dataclass
class Revisions:
    """Files of git revisions, each written to a temporary directory of its revision (at the
    same path as in the repository, so includes resolve as in a checkout), and how to name them.
    Only the files asked for, and what they include, are read: never the whole tree."""

    roots: dict[str, str] = field(default_factory=dict)        # commit → its temporary directory
    renames: dict[str, str] = field(default_factory=dict)      # shown prefix of a directory → the work tree's root
    top: Optional[str] = None                                  # the repository's work tree
    _commits: dict[str, str] = field(default_factory=dict)     # ref → commit
    _cat: Optional[_CatFile] = None

    def rename(self, file: str) -> str:
        """A file of a revision as the same file of the work tree is shown."""
        for tmp, top in self.renames.items():
            if file.startswith(tmp):
                return display_path(os.path.join(top, file[len(tmp):]))
        return file

    def rename_text(self, text: str) -> str:
        """Paths of a revision's files in a message, as the work tree's."""
        for tmp in self.renames:
            if tmp in text:
                text = re.sub(re.escape(tmp) + r"[^\s:,;)'\"]*", lambda m: self.rename(m.group(0)), text)
        return text

    def span(self, s: Span) -> Span:
        new = self.rename(s.file)
        return s if new == s.file else replace(s, file=new)

    def diagnostic(self, d: Diagnostic) -> Diagnostic:
        return replace(d, span=self.span(d.span), message=self.rename_text(d.message),
                       notes=tuple(self.rename_text(n) for n in d.notes),
                       related=tuple(replace(r, span=self.span(r.span), message=self.rename_text(r.message))
                                     for r in d.related))

    def close(self) -> None:
        if self._cat is not None:
            self._cat.close()
            self._cat = None
        for root in self.roots.values():
            shutil.rmtree(root, ignore_errors=True)

    # -- reading

    def toplevel(self, spec: str) -> str:
        if self.top is None:
            self.top = git(["rev-parse", "--show-toplevel"], os.getcwd(), spec).decode().strip()
        return self.top

    def commit(self, ref: str, spec: str) -> str:
        if ref not in self._commits:
            top = self.toplevel(spec)
            try:
                done = subprocess.run(["git", "rev-parse", "--verify", "--quiet", "--end-of-options",
                                       f"{ref}^{{commit}}"], cwd=top, capture_output=True, check=False)
            except FileNotFoundError:
                raise DiagnosticError([error("RC506", f"cannot read {spec}: git is not installed",
                                             Span.unknown("<git>"))]) from None
            if done.returncode != 0:
                raise DiagnosticError([error("RC506", f"cannot read {spec}: there is no revision '{ref}' in the "
                                             f"repository at {display_path(top)}", Span.unknown("<command line>"),
                                             notes=("a branch, tag or commit; in CI, fetch it first (actions/checkout "
                                                    "with fetch-depth: 0)",))])
            self._commits[ref] = done.stdout.decode().strip()
        return self._commits[ref]

    def fetch(self, ref: str, path: str, spec: str, includes: bool) -> str:
        """Write PATH of REF, and with `includes` every file it includes transitively, to REF's
        directory; the path to load. A missing include is left to the loader to report."""
        top = self.toplevel(spec)
        commit = self.commit(ref, spec)
        if commit not in self.roots:
            root = tempfile.mkdtemp(prefix="reconf-rev-")
            self.roots[commit] = root
            self.renames[display_path(root) + os.sep] = top
        root = self.roots[commit]
        if self._cat is None:
            self._cat = _CatFile(top)
        queue: list[tuple[str, Optional[Span]]] = [(path, None)]
        while queue:
            rel, at = queue.pop(0)
            dest = os.path.join(root, rel)
            if os.path.exists(dest):
                continue
            if "\n" in rel:
                raise DiagnosticError([error("RC506", f"cannot read {rel!r} from git: a path with a line break",
                                             at or Span.unknown("<command line>"))])
            kind, data, size = self._cat.blob(f"{commit}:{rel}", MAX_FILE_BYTES)
            if kind == "large":
                self._cat = None
                raise DiagnosticError([error("RC010", f"{rel} at {ref} is {size} bytes; the limit is {MAX_FILE_BYTES}",
                                             at or Span.unknown("<command line>"))])
            if data is None:
                if at is not None:
                    continue        # the loader reports the include it cannot find, where it is written
                what = "a directory" if kind == "tree" else "not in the repository" if kind in (
                    "symlink", "dangling", "loop", "notdir") else "missing"
                raise DiagnosticError([error("RC506", f"cannot read {spec}: {rel} is {what} at {ref}"
                                             if kind != "missing" else
                                             f"cannot read {spec}: there is no {rel} at {ref}",
                                             Span.unknown("<command line>"))])
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            with open(dest, "wb") as f:
                f.write(data)
            if includes:
                queue.extend(self._includes(root, rel, data, ref))
        return os.path.join(root, path)

    @staticmethod
    def _includes(root: str, rel: str, data: bytes, ref: str) -> list[tuple[str, Optional[Span]]]:
        """What the file includes, as paths in the repository; a file that does not parse
        includes nothing here (the loader reports why)."""
        try:
            doc = parse_text(data.decode("utf-8").removeprefix("\ufeff"), display_path(os.path.join(root, rel)))
        except (DiagnosticError, UnicodeDecodeError):
            return []
        out: list[tuple[str, Optional[Span]]] = []
        for item in doc.items:
            if not isinstance(item, ir.Include) or os.path.isabs(item.path):
                continue            # an absolute path is read from the disk, as in a checkout
            target = os.path.normpath(os.path.join(os.path.dirname(rel), item.path))
            if target == ".." or target.startswith(".." + os.sep):
                raise DiagnosticError([error("RC506", f"{rel} includes {item.path}, which is outside the "
                                             f"repository: it cannot be read from {ref}", item.span)])
            out.append((target, item.span))
        return out


def git(args: list[str], cwd: str, what: str) -> bytes:
    try:
        done = subprocess.run(["git", *args], cwd=cwd, capture_output=True, check=False)
    except FileNotFoundError:
        raise DiagnosticError([error("RC506", f"cannot read {what}: git is not installed",
                                     Span.unknown("<git>"))]) from None
    if done.returncode != 0:
        msg = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise DiagnosticError([error("RC506", f"cannot read {what}: {msg[-1] if msg else 'git failed'}",
                                     Span.unknown("<git>"))])
    return done.stdout


def split_ref(spec: str) -> tuple[str, str]:
    body = spec[len(GIT_PREFIX):]
    ref, sep, path = body.rpartition(":")
    if not sep or not ref or not path:
        raise DiagnosticError([error("RC506", f"'{spec}' is not git:REF:PATH", Span.unknown("<command line>"),
                                     notes=("for example git:origin/main:examples/robot.arch",))])
    return ref, path


@contextlib.contextmanager
def revisions() -> Iterator[Revisions]:
    revs = Revisions()
    try:
        yield revs
    finally:
        revs.close()


def path_to_load(spec: str, revs: Revisions, includes: bool = True) -> str:
    """A path to load for a path or a `git:REF:PATH` (with `includes`, what it includes is read too)."""
    if not spec.startswith(GIT_PREFIX):
        return spec
    ref, path = split_ref(spec)
    revs.toplevel(spec)
    if path.startswith("./") or path.startswith("../"):
        prefix = git(["rev-parse", "--show-prefix"], os.getcwd(), spec).decode().strip()
        path = os.path.join(prefix, path)
    path = os.path.normpath(path)
    if path == ".." or path.startswith(".." + os.sep) or os.path.isabs(path):
        raise DiagnosticError([error("RC506", f"cannot read {spec}: {path} is outside the repository",
                                     Span.unknown("<command line>"))])
    return revs.fetch(ref, path, spec, includes)


def rename_sources(sources: Sources, revs: Revisions) -> None:
    """The texts read from revisions under their work-tree names; a file of the work tree that
    was read too keeps its own text (the findings on it are on its lines)."""
    own = {key for key in sources.texts if revs.rename(key) == key}
    for key in list(sources.texts):
        new = revs.rename(key)
        if new == key:
            continue
        text = sources.texts.pop(key)
        if new not in own:
            sources.texts[new] = text
