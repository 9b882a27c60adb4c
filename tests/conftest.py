import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import pytest  # noqa: E402


@pytest.fixture
def here(tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    """An empty working directory with no policy (what the gate reads from where it runs)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".git").mkdir()  # stops the policy search here
    return tmp_path
