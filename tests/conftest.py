"""Tests in layers: `-m "not alloy"` runs without Java or the Alloy jar, `-m "not ros"` without
ROS 2 (tests/ros/conftest.py marks the live tests `ros`). The shared fixtures are in
tests/support/fixtures.py."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import pytest  # noqa: E402

# Every command the tests run is cold, whatever warm analyzer (`reconf daemon`, `reconf lsp`) the
# machine runs; tests/editor/test_warm.py starts its own, on a socket of its own.
os.environ["RECONF_NO_WARM"] = "1"

pytest_plugins = ["tests.support.fixtures"]

ALLOY_DIR = os.path.join(ROOT, "tests", "alloy") + os.sep


def needs_alloy(item: pytest.Item) -> bool:
    """A test in tests/alloy/, or one that asks for the `bridge` fixture (directly or through
    another fixture), needs the JVM and the Alloy jar."""
    return str(item.fspath).startswith(ALLOY_DIR) or "bridge" in getattr(item, "fixturenames", ())


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if needs_alloy(item) and item.get_closest_marker("alloy") is None:
            item.add_marker(pytest.mark.alloy)
