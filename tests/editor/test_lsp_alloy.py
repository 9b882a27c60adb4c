"""The Alloy proof on save in `reconf lsp` (a warm analyzer in the server), and an edit that
cancels a running proof."""
from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from lsprotocol import types as lsp

from bench.gen import generate
from tests.editor.conftest import WAIT, change, diagnostics_for, open_file, start

pytestmark = [pytest.mark.asyncio, pytest.mark.alloy]


def _save(client: object, uri: str) -> None:
    client.text_document_did_save(lsp.DidSaveTextDocumentParams(lsp.TextDocumentIdentifier(uri)))  # type: ignore[attr-defined]


async def test_the_verdict_of_the_proof_is_shown_on_save(project: Path) -> None:
    client = await start(project)
    try:
        path = project / "examples" / "chatter_slow.arch"
        uri = open_file(client, path)
        await diagnostics_for(client, uri, lambda ds: any(d.code == "RC201" for d in ds))
        _save(client, uri)
        found = await diagnostics_for(client, uri, lambda ds: any(d.code == "alloy" for d in ds), wait=3 * WAIT)
        verdict = next(d for d in found if d.code == "alloy")
        assert verdict.message.startswith("Alloy: unsafe, 1 assumption does not hold (proved by Alloy's evaluator")
        assert verdict.severity == lsp.DiagnosticSeverity.Information
        system_line = path.read_text().splitlines().index("system chatter")
        assert verdict.range.start.line == system_line
        change(client, uri, 2, path.read_text().replace("String @ 5 Hz", "String @ 10 Hz"))
        await diagnostics_for(client, uri, lambda ds: not ds)          # the verdict is stale after an edit
        _save(client, uri)
        found = await diagnostics_for(client, uri, lambda ds: any(d.code == "alloy" for d in ds), wait=3 * WAIT)
        assert [d.message.split(" (")[0] for d in found] == ["Alloy: safe, every assumption holds"]
    finally:
        await client.shutdown_session()


async def test_an_edit_cancels_a_running_proof(project: Path) -> None:
    client = await start(project)
    try:
        big = project / "big.arch"
        big.write_text(generate("dag", 2000, 1), encoding="utf-8")
        uri = open_file(client, big)
        await diagnostics_for(client, uri, lambda ds: True, wait=3 * WAIT)
        _save(client, uri)
        loop = asyncio.get_running_loop()
        deadline = loop.time() + 3 * WAIT
        while not any("proving" in m.message for m in client.log_messages):
            assert loop.time() < deadline, [m.message for m in client.log_messages]
            await asyncio.sleep(0.02)
        change(client, uri, 2, big.read_text() + "// edited\n")
        while not any("was cancelled" in m.message for m in client.log_messages):
            assert loop.time() < deadline, [m.message for m in client.log_messages]
            await asyncio.sleep(0.1)
        found = await diagnostics_for(client, uri, lambda ds: True)
        assert not any(d.code == "alloy" for d in found)
    finally:
        await client.shutdown_session()
