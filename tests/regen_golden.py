"""Regenerate the golden files: `python -m tests.regen_golden`. Review the diff before committing."""
from __future__ import annotations

import os

from tests.golden import GOLDEN_SETS


def main() -> None:
    for name, produce in GOLDEN_SETS.items():
        for key, text in produce():
            out = os.path.join(os.path.dirname(__file__), "golden", name, key)
            os.makedirs(os.path.dirname(out), exist_ok=True)
            with open(out, "w", encoding="utf-8") as f:
                f.write(text)
            print("wrote", os.path.relpath(out))


if __name__ == "__main__":
    main()
