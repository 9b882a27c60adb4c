"""The fault model a live FTM transition is run under comes from the FTM library: the faults the
example declares that the destination tolerates (the FTM rules refuse a mechanism that does not
tolerate a declared fault)."""
from __future__ import annotations

from pathlib import Path

import pytest

from checker.ftm.library import all_compositions
from reconf_ros.tools.livetest import faults_towards

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ftm" / "client_server_pbr_tr.arch"


@pytest.mark.parametrize("dst,faults", [("PBR", "crash"), ("LFR", "crash"), ("PBR(TR)", None),
                                        ("SEC(PBR(TR))", None)])
def test_the_destination_s_fault_model(dst: str, faults: str | None) -> None:
    assert faults_towards(EXAMPLE.read_text(), dst) == faults


def test_every_composition_keeps_only_what_it_tolerates() -> None:
    text = EXAMPLE.read_text()
    for comp in all_compositions():
        kept = faults_towards(text, str(comp))
        if kept is None:
            assert {"crash", "transient"} <= comp.covers, comp
        else:
            assert {f for f in kept.split(", ") if f} == {"crash", "transient"} & comp.covers, comp


def test_an_unknown_mechanism_is_an_error() -> None:
    with pytest.raises(ValueError, match="no mechanism XYZ"):
        faults_towards(EXAMPLE.read_text(), "XYZ")
