"""The language server's features, registered on a pygls server: documents opened, changed,
saved and closed; definition, references, hover, document symbols, formatting, completion."""
from __future__ import annotations

import asyncio
import os
from typing import Any, Optional

from lsprotocol import types as lsp
from pygls.lsp.server import LanguageServer

from checker.editor import convert, features
from checker.editor.index import Index, Occurrence
from checker.editor.server import Session, start_threads
from checker.editor.workspace import Analysis
from reconf_dsl.loader import display_path

SYMBOL_KINDS = {"component": lsp.SymbolKind.Class, "input": lsp.SymbolKind.Field, "output": lsp.SymbolKind.Field,
                "functionality": lsp.SymbolKind.Method, "topic": lsp.SymbolKind.Event,
                "service": lsp.SymbolKind.Interface, "message": lsp.SymbolKind.Struct, "host": lsp.SymbolKind.Object,
                "environment": lsp.SymbolKind.Constant}
COMPLETION_KINDS = {"keyword": lsp.CompletionItemKind.Keyword, "component": lsp.CompletionItemKind.Class,
                    "port": lsp.CompletionItemKind.Field, "message": lsp.CompletionItemKind.Struct,
                    "host": lsp.CompletionItemKind.Value, "ftm": lsp.CompletionItemKind.EnumMember,
                    "fault": lsp.CompletionItemKind.EnumMember, "application": lsp.CompletionItemKind.EnumMember,
                    "action": lsp.CompletionItemKind.EnumMember}


def make_server(alloy: bool = True, version: str = "0") -> tuple[LanguageServer, Session]:
    server = LanguageServer("reconf", version)
    session = Session(server, alloy=alloy)
    _documents(server, session)
    _navigation(server, session)
    _editing(server, session)
    return server, session


def _path(uri: str) -> str:
    return os.path.realpath(convert.path_of(uri))


def _documents(server: LanguageServer, session: Session) -> None:
    @server.feature(lsp.INITIALIZED)
    def initialized(params: lsp.InitializedParams) -> None:
        session.loop = asyncio.get_event_loop()
        folders = server.workspace.folders.values()
        session.ws.folders = [_path(f.uri) for f in folders] or ([_path(server.workspace.root_uri)]
                                                                if server.workspace.root_uri else [])
        start_threads(session)

    @server.feature(lsp.TEXT_DOCUMENT_DID_OPEN)
    def did_open(params: lsp.DidOpenTextDocumentParams) -> None:
        session.changed(_path(params.text_document.uri), params.text_document.text)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(params: lsp.DidChangeTextDocumentParams) -> None:
        uri = params.text_document.uri
        session.changed(_path(uri), server.workspace.get_text_document(uri).source)

    @server.feature(lsp.TEXT_DOCUMENT_DID_SAVE, lsp.SaveOptions(include_text=False))
    def did_save(params: lsp.DidSaveTextDocumentParams) -> None:
        session.saved(_path(params.text_document.uri))

    @server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(params: lsp.DidCloseTextDocumentParams) -> None:
        session.changed(_path(params.text_document.uri), None)

    @server.feature(lsp.SHUTDOWN)
    def shutdown(params: Any) -> None:
        session.events.put(("stop", ""))


def _where(session: Session, params: Any) -> tuple[str, int, int, list[Analysis]]:
    path = _path(params.text_document.uri)
    line, col = convert.from_position(session.codec, session.lines(path), params.position)
    return path, line, col, session.ws.analyses_of(path)


def _occurrence(session: Session, params: Any) -> tuple[Optional[Occurrence], list[Index]]:
    path, line, col, analyses = _where(session, params)
    indexes = [features.index_of(a) for a in analyses]
    for index in indexes:
        found = index.at(path, line, col)
        if found is not None:
            return found, indexes
    return None, indexes


def _location(session: Session, o: Occurrence) -> lsp.Location:
    rng = convert.to_range(session.codec, session.lines(o.path), o.line, o.col, o.line, o.end_col)
    return lsp.Location(convert.uri_of(o.path), rng)


def _unique(session: Session, occurrences: list[Occurrence]) -> list[lsp.Location]:
    seen = sorted({(o.path, o.line, o.col): o for o in occurrences}.values(), key=lambda o: (o.path, o.line, o.col))
    return [_location(session, o) for o in seen]


def _navigation(server: LanguageServer, session: Session) -> None:
    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    def definition(params: lsp.DefinitionParams) -> Optional[list[lsp.Location]]:
        def answer() -> Optional[list[lsp.Location]]:
            found, indexes = _occurrence(session, params)
            if found is None:
                return None
            return _unique(session, [d for i in indexes for d in i.declarations(found.key)]) or None
        return session.guarded("go to definition", answer)  # type: ignore[no-any-return]

    @server.feature(lsp.TEXT_DOCUMENT_REFERENCES)
    def references(params: lsp.ReferenceParams) -> Optional[list[lsp.Location]]:
        def answer() -> Optional[list[lsp.Location]]:
            found, indexes = _occurrence(session, params)
            if found is None:
                return None
            decl = params.context.include_declaration
            return _unique(session, [r for i in indexes for r in i.references(found.key, decl)])
        return session.guarded("find references", answer)  # type: ignore[no-any-return]

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    def hover(params: lsp.HoverParams) -> Optional[lsp.Hover]:
        return session.guarded("hover", lambda: _hover(session, params))  # type: ignore[no-any-return]

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def document_symbol(params: lsp.DocumentSymbolParams) -> Optional[list[lsp.DocumentSymbol]]:
        return session.guarded("document symbols", lambda: _symbols(session, params))  # type: ignore[no-any-return]


def _hover(session: Session, params: lsp.HoverParams) -> Optional[lsp.Hover]:
    path, line, col, analyses = _where(session, params)
    shown = display_path(path)
    for a in analyses:
        r = features.assumption_at(a, shown, line, col)
        if r is not None:
            return lsp.Hover(lsp.MarkupContent(lsp.MarkupKind.Markdown, features.hover_assumption(r, a)))
    found, indexes = _occurrence(session, params)
    if found is None:
        return None
    decls = [d for i in indexes for d in i.declarations(found.key)]
    text = None
    if decls:
        lines = session.lines(decls[0].path)
        text = lines[decls[0].line - 1] if decls[0].line <= len(lines) else None
    return lsp.Hover(lsp.MarkupContent(lsp.MarkupKind.Markdown, features.hover_name(found.key, decls, text)))


def _symbols(session: Session, params: lsp.DocumentSymbolParams) -> Optional[list[lsp.DocumentSymbol]]:
    path = _path(params.text_document.uri)
    for a in session.ws.analyses_of(path):
        doc = a.documents.get(path)
        if doc is None:
            continue
        lines = session.lines(path)

        def symbol(s: features.Symbol) -> lsp.DocumentSymbol:
            rng = convert.span_range(session.codec, lines, s.span)
            sel = (convert.to_range(session.codec, lines, s.selection.line, s.selection.col, s.selection.line,
                                    s.selection.end_col) if s.selection else rng)
            return lsp.DocumentSymbol(s.name, SYMBOL_KINDS.get(s.kind, lsp.SymbolKind.Variable), rng, sel,
                                      detail=s.kind, children=[symbol(k) for k in s.children] or None)
        return [symbol(s) for s in features.symbols(doc, features.index_of(a), path)]
    return None


def _editing(server: LanguageServer, session: Session) -> None:
    @server.feature(lsp.TEXT_DOCUMENT_FORMATTING)
    def formatting(params: lsp.DocumentFormattingParams) -> Optional[list[lsp.TextEdit]]:
        def answer() -> Optional[list[lsp.TextEdit]]:
            path = _path(params.text_document.uri)
            text = server.workspace.get_text_document(params.text_document.uri).source
            normal = text.replace("\r\n", "\n")
            done = features.formatted(normal, display_path(path))
            if done is None or done == normal:
                return [] if done is not None else None
            lines = text.splitlines(True) or [""]
            end = convert.position(session.codec, lines, len(lines), len(lines[-1]) + 1)
            newline = "\r\n" if "\r\n" in text.split("\n", 1)[0] + "\n" else "\n"
            return [lsp.TextEdit(lsp.Range(lsp.Position(0, 0), end), done.replace("\n", newline))]
        return session.guarded("formatting", answer)  # type: ignore[no-any-return]

    @server.feature(lsp.TEXT_DOCUMENT_COMPLETION, lsp.CompletionOptions(trigger_characters=[".", ">", ":", " "]))
    def completion(params: lsp.CompletionParams) -> Optional[lsp.CompletionList]:
        def answer() -> lsp.CompletionList:
            path, line, col, analyses = _where(session, params)
            text = server.workspace.get_text_document(params.text_document.uri).source
            lines = text.splitlines(True)
            offset = sum(len(x) for x in lines[:line - 1]) + col - 1
            found = features.complete(text, offset, analyses, display_path(path), line)
            items = [lsp.CompletionItem(c.label, kind=COMPLETION_KINDS.get(c.kind), detail=c.kind) for c in found]
            return lsp.CompletionList(is_incomplete=False, items=items)
        return session.guarded("completion", answer)  # type: ignore[no-any-return]
