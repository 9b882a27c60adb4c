"""The fixtures every test directory shares (registered by tests/conftest.py).

`bridge` is the real Alloy jar through JPype; the JVM starts once per session (per xdist worker).
A test that takes it is marked `alloy` by tests/conftest.py."""
from __future__ import annotations

from pathlib import Path

import pytest

from checker.alloy import AlloyBridge


@pytest.fixture(scope="session")
def bridge() -> AlloyBridge:
    return AlloyBridge.get()


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty working directory with no policy (what the gate reads from where it runs)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".git").mkdir()  # stops the policy search here
    return tmp_path
