"""English for the messages of every stage: a count and its noun in agreement."""
from __future__ import annotations

from typing import Optional


def plural(n: int, word: str, many: Optional[str] = None) -> str:
    """A count and its noun in agreement: `1 assumption`, `3 assumptions` (`many` when the
    plural is not the word and an s: `functionality`, `functionalities`)."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


def agree(n: int, one: str, many: str) -> str:
    """The words that agree with a count of `n`: agree(1, "does", "do") is "does"."""
    return one if n == 1 else many
