"""Mutants of the bundled examples through the command line keep the exit-code contract
(docs/exit-codes.md): 0, 1 or 2, no traceback, no RC000, JSON where JSON was asked for.
`python -m bench.fuzz` runs 5,000; the suite runs a few hundred of other seeds."""
from __future__ import annotations

import pytest

from bench.fuzz import Tally, mutants, run


def test_mutants_differ_and_are_reproducible() -> None:
    first = list(mutants(7, 50))
    assert first == list(mutants(7, 50))
    assert len({data for _, data in first}) > 40


@pytest.mark.parametrize("seed", [101, 102])
def test_mutants_keep_the_exit_code_contract(seed: int) -> None:
    tally = run(seed, 150, Tally())
    assert not tally.failures, "\n\n".join(tally.failures[:5])
    assert tally.runs >= 300 and set(tally.by_exit) <= {0, 1, 2}
    assert tally.by_exit.get(2, 0) and tally.by_exit.get(0, 0) + tally.by_exit.get(1, 0), tally.by_exit


def test_a_broken_contract_is_counted() -> None:
    """The tally is not a check that cannot fail."""
    tally = Tally()
    tally.add("x", 2, "", "reconf: error[RC000]: internal error", None, False, 0.0)
    tally.add("y", 1, "not json", "", None, True, 0.0)
    tally.add("z", 7, "", "Traceback (most recent call last):", ValueError("boom"), False, 0.0)
    assert len(tally.failures) == 3 and "exit 7" in tally.failures[2] and "escaped ValueError" in tally.failures[2]
