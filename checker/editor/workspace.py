"""What the language server knows of the files: the text of those the editor has open (which
wins over the disk), every file parsed once per text (a change reparses that file alone), the
include graph, and for each system the analysis `reconf check --engine python` makes of it.

A file is judged as part of the systems it belongs to: each file that includes it (directly or
not) and is included by none is loaded as `reconf check` would load it, with its includes. A
file that nothing includes is a system of its own. Diagnostics are kept per system and shown per
file, so an edit of an included file shows its effect in every file that includes it.

Paths: every key here is an absolute real path. The loader names files as `reconf check` does
(relative to the current directory, `loader.display_path`); `Workspace.base` is that directory
at start, and `absolute` maps a span's file back. All of it runs under `LOCK` (one parser, and
the warm `reconf check` changes the current directory while it holds it)."""
from __future__ import annotations

import hashlib
import os
import re
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any, Iterable, Optional

from checker.alloy.engines import Engine
from checker.gate.check import CheckOutcome, check_system
from reconf_dsl import ir
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError
from reconf_dsl.incremental import Incremental
from reconf_dsl.loader import STDIN, Budget, Sources, display_path, load_documents, read_source
from reconf_dsl.parser import parse_text
from reconf_dsl.resolve import resolve
from reconf_dsl.span import Span

LOCK = threading.RLock()
"""Held while anything parses, resolves or judges in this process (the parser is not re-entrant)."""

_INCLUDE = re.compile(r'^[ \t]*include[ \t]+"((?:[^"\\\n]|\\[^\n])*)"', re.MULTILINE)
SKIPPED_DIRS = {".git", ".venv", "node_modules", "__pycache__", "build", "dist"}


@dataclass
class Analysis:
    """One system as `reconf check --engine python` judges it: its files (real paths), what
    was parsed of each, the resolved system (None when it does not resolve), every diagnostic,
    and the Python engine's outcome."""

    root: str
    files: set[str]
    documents: dict[str, ir.Document]
    sources: Sources
    diagnostics: list[Diagnostic]
    system: Optional[ir.System] = None
    outcome: Optional[CheckOutcome] = None
    index: Any = None            # checker.editor.index.Index, made when first asked for
    texts: dict[str, str] = field(default_factory=dict)     # real path -> the text judged
    stale: bool = False          # `documents` are the last ones that parsed: this text does not
    document_texts: dict[str, str] = field(default_factory=dict)   # real path -> the text `documents` were read from


class ParseCache:
    """Each (file name, text) parsed once: a Document, or the DiagnosticError it raised; at
    most `PER_FILE` texts of one file (an undo finds the text before), `size` in all. A text
    not parsed before is parsed from the file's last text that parsed, where the edit did not
    reach it (`reconf_dsl.incremental`)."""

    PER_FILE = 2

    def __init__(self, size: int = 256) -> None:
        self._items: OrderedDict[tuple[str, str], Any] = OrderedDict()
        self._size = size
        self._incremental = Incremental(parse_text)
        self.hits = self.misses = 0

    def parse(self, text: str, file: str) -> ir.Document:
        key = (file, hashlib.sha1(text.encode("utf-8", "surrogatepass")).hexdigest())
        found = self._items.get(key)
        if found is None:
            self.misses += 1
            try:
                found = self._incremental.parse(text, file)
            except DiagnosticError as e:
                found = e
            self._items[key] = found
            older = [k for k in self._items if k[0] == file][:-self.PER_FILE]
            for k in older:                 # an edited file's earlier texts: only the last few are kept
                del self._items[k]
            if len(self._items) > self._size:
                self._items.popitem(last=False)
        else:
            self.hits += 1
            self._items.move_to_end(key)
        if isinstance(found, DiagnosticError):
            raise DiagnosticError(list(found.diagnostics))
        return found  # type: ignore[no-any-return]


@dataclass
class Workspace:
    base: str = field(default_factory=os.getcwd)
    folders: list[str] = field(default_factory=list)
    open: dict[str, str] = field(default_factory=dict)         # real path -> the editor's text
    cache: ParseCache = field(default_factory=ParseCache)
    analyses: dict[str, Analysis] = field(default_factory=dict)  # root -> its latest analysis
    _includes: dict[str, tuple[Any, tuple[str, ...]]] = field(default_factory=dict)

    def absolute(self, shown: str) -> str:
        """The real path of a file as a span names it."""
        return os.path.realpath(os.path.join(self.base, shown))

    def text(self, path: str) -> Optional[str]:
        """The editor's text of `path`, else the disk's; None when it cannot be read."""
        if path in self.open:
            return self.open[path]
        try:
            with open(path, encoding="utf-8") as f:
                return f.read()
        except (OSError, UnicodeDecodeError):
            return None

    def _read(self, path: str, sources: Sources, at: Optional[Span], budget: Budget) -> str:
        real = os.path.realpath(path) if path != STDIN else path
        if real not in self.open:
            return read_source(path, sources, at, budget)
        text = self.open[real]
        budget.remaining -= len(text.encode("utf-8"))
        sources.texts[display_path(path)] = text
        return text

    def includes(self, path: str) -> tuple[str, ...]:
        """The real paths `path` includes, read off its text (kept until the text changes)."""
        text = self.open.get(path)
        stamp: Any = hash(text) if text is not None else _stamp(path)
        kept = self._includes.get(path)
        if kept is not None and kept[0] == stamp:
            return kept[1]
        text = text if text is not None else self.text(path)
        found = tuple(os.path.realpath(os.path.join(os.path.dirname(path), m.group(1)))
                      for m in _INCLUDE.finditer(text or ""))
        self._includes[path] = (stamp, found)
        return found

    def known_files(self) -> set[str]:
        """The open files and every .arch file under the workspace's folders."""
        found = set(self.open)
        for folder in self.folders:
            for directory, dirs, files in os.walk(folder):
                dirs[:] = [d for d in dirs if d not in SKIPPED_DIRS and not d.startswith(".")]
                found.update(os.path.realpath(os.path.join(directory, f)) for f in files if f.endswith(".arch"))
        return found

    def roots(self, path: str) -> list[str]:
        """The files to load so that `path` is judged: those that include it, directly or
        not, and that nothing includes; `path` itself when nothing includes it."""
        parents: dict[str, set[str]] = {}
        for f in self.known_files() | {path}:
            for g in self.includes(f):
                parents.setdefault(g, set()).add(f)
        seen, todo, tops = {path}, [path], []
        while todo:
            f = todo.pop()
            ups = parents.get(f, set()) - {f}
            if not ups:
                tops.append(f)
            for g in ups - seen:
                seen.add(g)
                todo.append(g)
        return sorted(tops) or [path]

    def analyse(self, root: str) -> Analysis:
        """Load `root` as `reconf check` does (the editor's texts first) and judge it with the
        Python engine; every failure is in `diagnostics`."""
        with LOCK:
            sources = Sources()
            documents: dict[str, ir.Document] = {}
            analysis = Analysis(root, {root}, documents, sources, [])
            try:
                docs = load_documents([display_path(root)], sources, reader=self._read, parse=self.cache.parse)
            except DiagnosticError as e:
                analysis.diagnostics = list(e.diagnostics)
                analysis.files |= {self.absolute(f) for f in sources.texts}
                previous = self.analyses.get(root)
                if previous is not None:        # what was last read of it, for names while the text is broken
                    documents.update(previous.documents)
                    analysis.stale, analysis.index = True, previous.index
                    analysis.document_texts = previous.document_texts
                return self._keep(analysis)
            documents.update({self.absolute(d.file): d for d in docs})
            analysis.files |= set(documents)
            try:
                analysis.system = resolve(docs)
                analysis.outcome = check_system(analysis.system, Engine.PYTHON)
                analysis.diagnostics = analysis.outcome.diagnostics
            except DiagnosticError as e:
                analysis.diagnostics = list(e.diagnostics)
            return self._keep(analysis)

    def _keep(self, analysis: Analysis) -> Analysis:
        analysis.texts = {self.absolute(shown): text for shown, text in analysis.sources.texts.items()}
        if not analysis.stale:
            analysis.document_texts = analysis.texts
        self.analyses[analysis.root] = analysis
        return analysis

    def diagnostics_of(self, path: str) -> list[Diagnostic]:
        """Every diagnostic located in `path`, from every system it belongs to, once each."""
        out: list[Diagnostic] = []
        seen: set[Diagnostic] = set()
        for analysis in list(self.analyses.values()):
            if path not in analysis.files:
                continue
            for d in analysis.diagnostics:
                if d not in seen and self._located_in(d, path):
                    seen.add(d)
                    out.append(d)
        return out

    def _located_in(self, d: Diagnostic, path: str) -> bool:
        return not d.span.file.startswith("<") and self.absolute(d.span.file) == path

    def analyses_of(self, path: str) -> list[Analysis]:
        return [a for a in self.analyses.values() if path in a.files]

    def forget(self, roots: Iterable[str]) -> None:
        for root in roots:
            self.analyses.pop(root, None)


def _stamp(path: str) -> Any:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size)
