"""`reconf lsp`: the language server (pygls, over standard input and output).

As the user types, the file and every file of the systems it belongs to are judged by the
Python engine (`workspace.Workspace.analyse`) on a thread of their own, and every diagnostic
`reconf check` would print is published where it points. On save, a warm Alloy Analyzer (one
JVM for the session, started when the client connects) proves each of those systems on a
second thread; its verdict is shown at the system's declaration (a disagreement between the
engines as the error RC300), and an edit while it runs cancels it (`checker.alloy.cancel`).

A file that cannot be read or parsed gives diagnostics, never an error of the server: every
handler and both threads report an unexpected failure to the client's log and go on."""
from __future__ import annotations

import asyncio
import functools
import os
import queue
import threading
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from lsprotocol import types as lsp
from pygls.lsp.server import LanguageServer

from checker.alloy.cancel import Cancelled, cancellable
from checker.alloy.engines import Engine, EnginesDisagree, EngineUnavailable
from checker.alloy.errors import AlloyUnavailable
from checker.alloy.evaluate import start_early
from checker.editor import convert, features
from checker.editor.workspace import LOCK, Analysis, Workspace
from checker.gate.check import check_system
from reconf_dsl.loader import display_path
from reconf_dsl.words import plural

DEBOUNCE = 0.02      # seconds an edit waits for the next one before the files are judged


@dataclass
class Proof:
    """One Alloy proof of a system, and its verdict as a status at the system's declaration."""

    root: str
    cancelled: bool = False
    status: Optional[tuple[str, Any, str, lsp.DiagnosticSeverity, str]] = None   # path, span, message, severity, code


@dataclass
class Session:
    server: LanguageServer
    ws: Workspace = field(default_factory=Workspace)
    events: "queue.Queue[tuple[str, str]]" = field(default_factory=queue.Queue)
    statuses: dict[str, Proof] = field(default_factory=dict)      # root -> its last proof
    published: dict[str, set[str]] = field(default_factory=dict)  # root -> the files its diagnostics went to
    proving: Optional[Proof] = None
    loop: Optional[asyncio.AbstractEventLoop] = None
    alloy: bool = True
    warm: bool = True                                             # serve `reconf check` over a local socket
    timings: list[float] = field(default_factory=list)            # seconds from an edit to its diagnostics
    _lines: dict[str, tuple[Optional[str], list[str]]] = field(default_factory=dict)

    # ------------------------------------------------------------------ reporting to the client

    def log(self, message: str, kind: lsp.MessageType = lsp.MessageType.Log) -> None:
        self.call(lambda: self.server.window_log_message(lsp.LogMessageParams(kind, message)))

    def call(self, fn: Callable[[], None]) -> None:
        """Run `fn` on the server's event loop (what writes to the client is not thread-safe)."""
        if self.loop is not None and self.loop.is_running():
            self.loop.call_soon_threadsafe(fn)
        else:
            fn()

    def guarded(self, what: str, fn: Callable[[], Any], default: Any = None) -> Any:
        try:
            return fn()
        except Exception as e:  # noqa: BLE001 - the server goes on whatever one request does
            self.log(f"reconf: {what} failed: {type(e).__name__}: {e}\n{traceback.format_exc()}",
                     lsp.MessageType.Error)
            return default

    # ------------------------------------------------------------------ texts and positions

    def lines(self, path: str) -> list[str]:
        """The lines of `path` as the editor has it, else as last judged, else on disk (kept
        while the text is the same: a diagnostic's chain asks for them once a link)."""
        text = self.ws.open.get(path)
        for a in list(self.ws.analyses.values()):
            text = text if text is not None else a.texts.get(path)
        text = text if text is not None else self.ws.text(path)
        kept = self._lines.get(path)
        if kept is not None and kept[0] is text:
            return kept[1]
        lines = (text or "").splitlines(True) or [""]
        self._lines[path] = (text, lines)
        return lines

    @property
    def codec(self) -> Any:
        return self.server.workspace.position_codec

    # ------------------------------------------------------------------ judging as the user types

    def changed(self, path: str, text: Optional[str]) -> None:
        if text is None:
            self.ws.open.pop(path, None)
        else:
            self.ws.open[path] = text
        if self.proving is not None:
            self.proving.cancelled = True
        self.events.put(("change", path))

    def saved(self, path: str) -> None:
        self.events.put(("save", path))

    def work(self) -> None:
        """The analysis thread: takes every edit that arrived, judges the systems they touch,
        publishes, then starts the proofs of the saved ones."""
        while True:
            kind, path = self.events.get()
            if kind == "stop":
                return
            time.sleep(DEBOUNCE)
            changed, saved = {path} if kind == "change" else set(), {path} if kind == "save" else set()
            while not self.events.empty():
                k, p = self.events.get()
                if k == "stop":
                    return
                (changed if k == "change" else saved).add(p)
                if k == "change" and p in saved:    # edited after its save: what was saved is gone
                    saved.discard(p)
                    self.log(f"reconf: not proved: {display_path(p)} was edited after it was saved")
            self.guarded("judging the files", lambda: self._judge(changed, saved))

    def _judge(self, changed: set[str], saved: set[str]) -> None:
        started = time.perf_counter()
        with LOCK:
            roots = sorted({r for p in changed | saved for r in self.ws.roots(p)})
            analyses = [self.ws.analyse(r) for r in roots]
        for root in roots:
            if changed and root in self.statuses and self.statuses[root].status is not None:
                self.statuses.pop(root)              # not proved since the edit
        self.publish(roots)
        if changed:
            self.timings.append(time.perf_counter() - started)
        if saved and self.alloy:
            self.prove([a for a in analyses if a.system is not None])

    def publish(self, roots: list[str]) -> None:
        files = set()
        for root in roots:
            now = self.ws.analyses[root].files if root in self.ws.analyses else set()
            files |= now | self.published.get(root, set())
            self.published[root] = set(now)
        for path in sorted(files):
            params = lsp.PublishDiagnosticsParams(convert.uri_of(path), self._diagnostics(path))
            self.call(functools.partial(self.server.text_document_publish_diagnostics, params))

    def _diagnostics(self, path: str) -> list[lsp.Diagnostic]:
        out = [convert.diagnostic(d, self.codec, self.lines, self.ws.absolute) for d in self.ws.diagnostics_of(path)]
        for proof in self.statuses.values():
            if proof.status is not None and proof.status[0] == path:
                _, span, message, severity, code = proof.status
                out.append(convert.status_diagnostic(message, self.codec, self.lines(path), span, severity, code))
        return out

    # ------------------------------------------------------------------ the proof on save

    def prove(self, analyses: list[Analysis]) -> None:
        if self.proving is not None:
            self.proving.cancelled = True
        proofs = [Proof(a.root) for a in analyses]
        thread = threading.Thread(target=self._prove_all, args=(proofs, analyses), name="reconf-proof", daemon=True)
        thread.start()

    def _prove_all(self, proofs: list[Proof], analyses: list[Analysis]) -> None:
        for proof, analysis in zip(proofs, analyses):
            self.proving = proof
            self.log(f"reconf: proving {display_path(proof.root)} in Alloy")
            self.guarded("the Alloy proof", lambda: self._prove(proof, analysis))
            if proof.cancelled:
                self.log(f"reconf: the Alloy proof of {display_path(proof.root)} was cancelled: the file changed")
                return
            self.statuses[proof.root] = proof
            self.publish([proof.root])
        self.proving = None

    def _prove(self, proof: Proof, analysis: Analysis) -> None:
        system = analysis.system
        assert system is not None
        where = self.ws.absolute(system.span.file)
        started = time.perf_counter()
        try:
            with cancellable(lambda: proof.cancelled):
                outcome = check_system(system, Engine.BOTH,
                                       python=analysis.outcome.judged.python if analysis.outcome else None)
        except Cancelled:
            proof.cancelled = True
            return
        except EnginesDisagree as e:
            proof.status = (where, system.span, e.diagnostic.message + "".join(f"\nnote: {n}" for n in e.diagnostic.notes),
                            lsp.DiagnosticSeverity.Error, "RC300")
            return
        except (EngineUnavailable, AlloyUnavailable) as e:
            d = getattr(e, "diagnostic", None)
            proof.status = (where, system.span, f"no Alloy proof: {d.message if d else e}",
                            lsp.DiagnosticSeverity.Warning, d.code if d else "RC301")
            return
        seconds = time.perf_counter() - started
        proof.status = (where, system.span, _verdict(outcome, seconds), lsp.DiagnosticSeverity.Information, "alloy")


def _verdict(outcome: Any, seconds: float) -> str:
    """The proof's verdict in one line, as `reconf check` says it."""
    bad = len(outcome.judged.python.unsatisfied)
    held = ("every assumption holds" if outcome.judged.valid
            else f"{plural(bad, 'assumption')} {'does' if bad == 1 else 'do'} not hold")
    verdict = "safe" if outcome.safe else "unsafe"
    how = outcome.judged.how().strip(" ()")
    return f"Alloy: {verdict}, {held} ({how}; {seconds:.2f} s)"


def start_threads(session: Session) -> None:
    threading.Thread(target=session.work, name="reconf-analysis", daemon=True).start()
    if session.alloy and os.environ.get("RECONF_LSP_NO_ALLOY", "") in ("", "0"):
        start_early()            # the JVM and the evaluation module, while the client opens files
