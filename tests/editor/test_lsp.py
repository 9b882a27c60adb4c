"""`reconf lsp` end to end: a real client, the real server process."""
from __future__ import annotations

from pathlib import Path

import pytest
from lsprotocol import types as lsp
from pytest_lsp import LanguageClient

from tests.editor.conftest import change, diagnostics_for, open_file

pytestmark = pytest.mark.asyncio


async def test_an_assumption_that_does_not_hold_is_shown_with_its_chain(client: LanguageClient, project: Path) -> None:
    uri = open_file(client, project / "examples" / "chatter_slow.arch")
    found = await diagnostics_for(client, uri, lambda ds: any(d.code == "RC201" for d in ds))
    d = next(d for d in found if d.code == "RC201")
    assert (d.range.start.line, d.range.start.character) == (20, 20)          # 21:21, as `reconf check` says
    assert d.severity == lsp.DiagnosticSeverity.Error and d.source == "reconf"
    assert "listener.listen assumes String @ 10 Hz, which does not hold" in d.message
    chain = [(r.message.strip(), r.location.range.start.line + 1) for r in d.related_information or []]
    assert chain[0] == ("input listener.in assumes String @ 10 Hz", 18)
    assert any("rate too low: 5 Hz < 10 Hz" in m and line == 10 for m, line in chain), chain


async def test_an_edit_is_judged_as_typed(client: LanguageClient, project: Path) -> None:
    path = project / "examples" / "chatter_slow.arch"
    uri = open_file(client, path)
    await diagnostics_for(client, uri, lambda ds: any(d.code == "RC201" for d in ds))
    change(client, uri, 2, path.read_text().replace("String @ 5 Hz", "String @ 10 Hz"))
    await diagnostics_for(client, uri, lambda ds: not ds)


async def test_a_bad_file_never_stops_the_server(client: LanguageClient, project: Path) -> None:
    path = project / "examples" / "chatter.arch"
    uri = open_file(client, path, 'system s\ncomponent c { run "x\n')
    found = await diagnostics_for(client, uri, lambda ds: bool(ds))
    assert [d.code for d in found] == ["RC003"] and found[0].range.start.line == 1
    for version, text in enumerate(["\x00\ufeff{{{", "(" * 5000, "system s\ncomponent c { ftm " + "A(" * 500, ""], 2):
        change(client, uri, version, text)
    await diagnostics_for(client, uri, lambda ds: [d.code for d in ds] == ["RC006"] or any("empty" in d.message for d in ds))
    change(client, uri, 10, path.read_text())
    await diagnostics_for(client, uri, lambda ds: not ds)
    hover = await client.text_document_hover_async(lsp.HoverParams(lsp.TextDocumentIdentifier(uri), lsp.Position(0, 0)))
    assert hover is None or hover.contents is not None


async def test_an_included_file_is_judged_in_the_files_that_include_it(client: LanguageClient, project: Path) -> None:
    messages = project / "examples" / "common" / "messages.arch"
    robot = project / "examples" / "robot.arch"
    uri = open_file(client, messages)
    await diagnostics_for(client, robot.as_uri(), lambda ds: not ds)
    text = messages.read_text()
    assert "message Image" in text
    change(client, uri, 2, "\n".join(ln for ln in text.splitlines() if not ln.startswith("message Image")) + "\n")
    found = await diagnostics_for(client, robot.as_uri(), lambda ds: any(d.code == "RC101" for d in ds))
    assert all("Image" in d.message for d in found if d.code == "RC101")


def _at(uri: str, line: int, col: int) -> lsp.TextDocumentPositionParams:
    """1-based line and column, as reconf shows them."""
    return lsp.TextDocumentPositionParams(lsp.TextDocumentIdentifier(uri), lsp.Position(line - 1, col - 1))


async def _opened(client: LanguageClient, project: Path, name: str = "chatter.arch") -> str:
    uri = open_file(client, project / "examples" / name)
    await diagnostics_for(client, uri, lambda ds: True)
    return uri


async def test_go_to_definition_of_a_port_a_component_and_a_message_type(client: LanguageClient, project: Path) -> None:
    uri = await _opened(client, project)
    where = _at(uri, 42, 10)                                   # `talker.out -> listener.in`: the `out` of talker.out
    found = await client.text_document_definition_async(lsp.DefinitionParams(**_kw(where)))
    assert [(loc.range.start.line + 1, loc.range.start.character + 1) for loc in found] == [(10, 10)]
    where = _at(uri, 42, 4)                                    # `talker`
    found = await client.text_document_definition_async(lsp.DefinitionParams(**_kw(where)))
    assert [(loc.range.start.line + 1, loc.range.start.character + 1) for loc in found] == [(7, 11)]
    where = _at(uri, 10, 16)                                   # `output out: String`
    found = await client.text_document_definition_async(lsp.DefinitionParams(**_kw(where)))
    assert [(loc.range.start.line + 1, loc.range.start.character + 1) for loc in found] == [(5, 9)]


async def test_references_of_a_message_type_and_a_host(client: LanguageClient, project: Path) -> None:
    uri = await _opened(client, project)
    where = _at(uri, 5, 10)                                    # `message String = ...`
    refs = await client.text_document_references_async(lsp.ReferenceParams(
        context=lsp.ReferenceContext(include_declaration=True), **_kw(where)))
    lines = sorted(r.range.start.line + 1 for r in refs)
    assert lines == [5, 10, 13, 22, 25, 33, 36, 41], lines
    where = _at(uri, 9, 8)                                     # `host robot`
    refs = await client.text_document_references_async(lsp.ReferenceParams(
        context=lsp.ReferenceContext(include_declaration=False), **_kw(where)))
    assert sorted(r.range.start.line + 1 for r in refs) == [9, 21, 32]


async def test_hover_on_an_assumption_says_whether_it_holds_and_why(client: LanguageClient, project: Path) -> None:
    uri = await _opened(client, project, "chatter_slow.arch")
    hover = await client.text_document_hover_async(lsp.HoverParams(**_kw(_at(uri, 21, 25))))
    text = hover.contents.value
    assert "listener.listen" in text and "does not hold" in text and "rate too low: 5 Hz < 10 Hz" in text, text
    uri = await _opened(client, project)
    hover = await client.text_document_hover_async(lsp.HoverParams(**_kw(_at(uri, 36, 21))))
    assert "✓ holds" in hover.contents.value and "/chatter" in hover.contents.value


def _kw(p: lsp.TextDocumentPositionParams) -> dict[str, object]:
    return {"text_document": p.text_document, "position": p.position}


async def test_document_symbols(client: LanguageClient, project: Path) -> None:
    uri = await _opened(client, project)
    found = await client.text_document_document_symbol_async(lsp.DocumentSymbolParams(lsp.TextDocumentIdentifier(uri)))
    names = [(s.name, s.detail) for s in found]
    assert names == [("String", "message"), ("talker", "component"), ("talker_v2", "component"),
                     ("listener", "component"), ("/chatter", "topic")]
    talker = found[1]
    assert [(k.name, k.detail) for k in talker.children] == [("out", "output"), ("talk", "functionality")]
    assert (talker.selection_range.start.line, talker.selection_range.start.character) == (6, 10)


async def test_formatting_is_reconf_fmt(client: LanguageClient, project: Path) -> None:
    path = project / "examples" / "chatter.arch"
    messy = path.read_text().replace("\n  ", "\n        ").replace("component listener {", "component   listener{")
    uri = open_file(client, path, messy)
    edits = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
        lsp.TextDocumentIdentifier(uri), lsp.FormattingOptions(tab_size=2, insert_spaces=True)))
    assert len(edits) == 1 and edits[0].new_text == path.read_text()


async def test_completion_of_names_where_the_grammar_expects_one(client: LanguageClient, project: Path) -> None:
    path = project / "examples" / "chatter.arch"
    text = path.read_text()
    uri = await _opened(client, project)
    cut = text.index("talker.out -> listener.in") + len("talker.out -> listener.")
    edited = text[:cut] + "\n}\n"
    change(client, uri, 2, edited)
    lines = edited[:cut].splitlines()
    items = await client.text_document_completion_async(lsp.CompletionParams(
        lsp.TextDocumentIdentifier(uri), lsp.Position(len(lines) - 1, len(lines[-1]))))
    assert [i.label for i in items.items] == ["in"]
    cut = text.index("talker.out -> ") + len("talker.out -> ")
    lines = text[:cut].splitlines()
    change(client, uri, 3, text)
    items = await client.text_document_completion_async(lsp.CompletionParams(
        lsp.TextDocumentIdentifier(uri), lsp.Position(len(lines) - 1, len(lines[-1]))))
    assert {"listener", "talker"} <= {i.label for i in items.items} and "talker_v2" not in {i.label for i in items.items}
    cut = text.index("  output out: String") + 2
    lines = text[:cut].splitlines()
    items = await client.text_document_completion_async(lsp.CompletionParams(
        lsp.TextDocumentIdentifier(uri), lsp.Position(len(lines) - 1, len(lines[-1]))))
    assert {"input", "output", "functionality", "host"} <= {i.label for i in items.items}
    cut = text.index("  output out: String\n") + len("  output out: String\n")
    typed = text[:cut] + "  takes create 2 s, "
    change(client, uri, 4, typed + "\n" + text[cut:])
    lines = typed.splitlines()
    items = await client.text_document_completion_async(lsp.CompletionParams(
        lsp.TextDocumentIdentifier(uri), lsp.Position(len(lines) - 1, len(lines[-1]))))
    assert [i.label for i in items.items] == ["remove", "create", "detach", "attach", "degrade", "upgrade"]
