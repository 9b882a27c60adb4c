"""`reconf ftm select` in text: the columns of both lists line up, whatever the names' lengths."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from checker.cli.ftm_cmd import columns, ftm_group
from tests.support.ftm import EXAMPLES


def _select(example: str, *args: str) -> str:
    r = CliRunner().invoke(ftm_group, ["select", "server", "-f", f"{EXAMPLES}/{example}", "--no-alloy", *args])
    assert r.exit_code in (0, 1), r.output
    return r.stdout if args else r.stderr


def _block(text: str, title: str) -> list[str]:
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(title)) + 1
    end = next((i for i in range(start, len(lines)) if not lines[i].strip()), len(lines))
    return lines[start:end]


def _at(line: str, cells: list[str]) -> list[tuple[int, int]]:
    """Where each cell stands in `line`, searched in order: (start, end)."""
    out, pos = [], 0
    for cell in cells:
        start = line.index(cell, pos)
        out.append((start, start + len(cell)))
        pos = start + len(cell)
    return out


@pytest.mark.parametrize("example", ["client_server_pbr_tr.arch", "deterministic_lfr.arch", "client_server_pbr.arch"])
def test_the_columns_line_up(example: str) -> None:
    doc = json.loads(_select(example, "--output-format", "json"))
    text = _select(example)
    header, *rows = _block(text, "Valid")
    assert len(rows) == len(doc["valid"]) > 1
    names = ["FTM", "covers", "CPUs", "bandwidth", "nodes"]
    where = dict(zip(names, _at(header, names)))
    for line, c in zip(rows, doc["valid"]):
        cells = [c["ftm"], ", ".join(c["covers"]), str(c["cpus"]), c["bandwidth"], str(c["nodes"])]
        at = dict(zip(names, _at(line, cells)))
        for left in ("FTM", "covers", "bandwidth"):     # words start under their heading
            assert at[left][0] == where[left][0], (left, line)
        for right in ("CPUs", "nodes"):                # numbers end under theirs
            assert at[right][1] == where[right][1], (right, line)
    ruled = _block(text, "Ruled out")
    assert len(ruled) == len(doc["rejected"]) > 1
    starts = set()
    for line, c in zip(ruled, doc["rejected"]):
        (name, _), (reason, _) = _at(line, [c["ftm"], c["reasons"][0]["text"]])
        starts.add(reason)
        assert line[:name].strip() == "✗"
    assert len(starts) == 1, ruled


def test_columns_pads_to_the_widest_cell() -> None:
    assert columns([["1.", "AD", "x"], ["10.", "SEC(PBR(TR))", "y"]], frozenset({0})) == [
        " 1.  AD            x", "10.  SEC(PBR(TR))  y"]
