"""The Alloy tests use the real jar through JPype; the JVM starts once per session."""
from __future__ import annotations

import pytest

from checker.alloy import AlloyBridge


@pytest.fixture(scope="session")
def bridge() -> AlloyBridge:
    return AlloyBridge.get()
