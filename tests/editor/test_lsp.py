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
