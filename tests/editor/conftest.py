"""A real language client (pytest-lsp's) talking to a real `reconf lsp` process, started in a
scratch copy of examples/ (its current directory), as an editor starts it."""
from __future__ import annotations

import asyncio
import os
import shutil
import sys
from pathlib import Path
from typing import AsyncIterator, Callable

import pytest
import pytest_asyncio
from lsprotocol import types as lsp
from pytest_lsp import LanguageClient, client_capabilities, make_test_lsp_client

from tests.examples_table import ROOT

WAIT = 60.0     # seconds for one answer: a slow shared machine does not fail a test, a hang does


@pytest.fixture
def project(tmp_path: Path) -> Path:
    shutil.copytree(os.path.join(ROOT, "examples"), tmp_path / "examples")
    return tmp_path


def server_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "checker", "lsp", "--no-warm", *args]


async def start(project: Path, *args: str, env: dict[str, str] | None = None) -> LanguageClient:
    client = make_test_lsp_client()
    environ = dict(os.environ, PYTHONPATH=ROOT, RECONF_NO_WARM="1", **(env or {}))
    await client.start_io(*server_command(*args), cwd=str(project), env=environ)
    await client.initialize_session(lsp.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"), root_uri=project.as_uri(),
        workspace_folders=[lsp.WorkspaceFolder(project.as_uri(), "project")]))
    return client


@pytest_asyncio.fixture
async def client(project: Path) -> AsyncIterator[LanguageClient]:
    c = await start(project, "--no-alloy")
    yield c
    await c.shutdown_session()


async def diagnostics_for(client: LanguageClient, uri: str, until: Callable[[list[lsp.Diagnostic]], bool],
                          wait: float = WAIT) -> list[lsp.Diagnostic]:
    """The diagnostics the server publishes for `uri`, once `until` holds of them."""
    deadline = asyncio.get_running_loop().time() + wait
    while True:
        found = list(client.diagnostics.get(uri, []))
        if uri in client.diagnostics and until(found):
            return found
        left = deadline - asyncio.get_running_loop().time()
        if left <= 0:
            raise AssertionError(f"no diagnostics as expected for {uri} in {wait} s; last: {found}")
        try:
            await asyncio.wait_for(client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), left)
        except asyncio.TimeoutError:
            pass


def open_file(client: LanguageClient, path: Path, text: str | None = None) -> str:
    uri = path.as_uri()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(
        lsp.TextDocumentItem(uri=uri, language_id="reconf", version=1, text=path.read_text() if text is None else text)))
    return uri


def change(client: LanguageClient, uri: str, version: int, text: str) -> None:
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=version), [lsp.TextDocumentContentChangeWholeDocument(text=text)]))
