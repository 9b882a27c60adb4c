"""The FTM library: Table I (what each mechanism tolerates, needs and costs) and Table II
(what its Before, Proceed and After do, per replica role), as data (docs/ftm.md#the-library).

A mechanism belongs to one *layer*: `sec` (outermost), `dup` (the duplex patterns PBR, LFR,
A&D; two replicas) or `tr` (innermost). A composition is written outermost first, one
mechanism per layer at most, in that order: `SEC(PBR(TR))`. Since the order is fixed, a
composition is determined by its set of mechanisms.

Where Table I is silent or garbled (A&D's duplex, what SEC tolerates and needs, `omission`), the
readings taken are in docs/ftm.md#the-library.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from reconf_dsl.ir import FtmExpr

__all__ = ["Mechanism", "LIBRARY", "LAYER_ORDER", "BANDWIDTH", "bandwidth_rank", "layers", "Composition",
           "compose", "all_compositions", "RoleSpec", "roles"]

BANDWIDTH = ("nil", "low", "medium", "high")
LAYER_ORDER = ("sec", "dup", "tr")


def bandwidth_rank(level: str) -> int:
    return BANDWIDTH.index(level)


@dataclass(frozen=True)
class RoleSpec:
    """What one replica's Before / Proceed / After do for a mechanism (Table II); None = nothing
    (the node passes the request or result through)."""

    role: str
    before: str
    proceed: str
    after: str


@dataclass(frozen=True)
class Mechanism:
    name: str
    title: str
    layer: str
    covers: frozenset[str]
    needs: frozenset[str]           # application characteristics required
    bandwidth: str                  # least bandwidth needed
    cpus: int
    replicas: tuple[RoleSpec, ...]  # one per replica

    @property
    def duplex(self) -> bool:
        return len(self.replicas) == 2


LIBRARY: dict[str, Mechanism] = {m.name: m for m in (
    Mechanism("PBR", "primary-backup replication", "dup", frozenset({"crash"}), frozenset({"state_access"}),
              "high", 2, (RoleSpec("primary", "pass_request", "compute", "checkpoint"),
                          RoleSpec("backup", "pass_request", "compute", "update_state"))),
    Mechanism("LFR", "leader-follower replication", "dup", frozenset({"crash"}), frozenset({"deterministic"}),
              "low", 2, (RoleSpec("leader", "forward_request", "compute", "notify"),
                         RoleSpec("follower", "handle_request", "compute", "handle_notification"))),
    Mechanism("AD", "assertion and duplex", "dup", frozenset({"crash", "transient", "permanent_value"}),
              frozenset({"deterministic"}), "low", 2,
              (RoleSpec("leader", "forward_request", "compute", "assert_result"),
               RoleSpec("follower", "handle_request", "compute", "assert_result"))),
    Mechanism("TR", "time redundancy", "tr", frozenset({"transient"}), frozenset({"deterministic", "state_access"}),
              "nil", 1, (RoleSpec("single", "save_restore_state", "compute", "compare"),)),
    Mechanism("SEC", "ciphering and signature", "sec", frozenset({"intrusion"}), frozenset(), "nil", 1,
              (RoleSpec("single", "decipher_check", "compute", "cipher_sign"),)),
)}


def layers(expr: FtmExpr) -> list[str]:
    """`SEC(PBR(TR))` → ["SEC", "PBR", "TR"], outermost first."""
    out: list[str] = []
    e: Optional[FtmExpr] = expr
    while e is not None:
        out.append(e.name)
        e = e.inner
    return out


@dataclass(frozen=True)
class Composition:
    """Mechanisms outermost first, in layer order."""

    names: tuple[str, ...]

    @property
    def mechanisms(self) -> tuple[Mechanism, ...]:
        return tuple(LIBRARY[n] for n in self.names)

    @property
    def covers(self) -> frozenset[str]:
        return frozenset().union(*(m.covers for m in self.mechanisms))

    @property
    def needs(self) -> frozenset[str]:
        return frozenset().union(*(m.needs for m in self.mechanisms))

    @property
    def bandwidth(self) -> str:
        return max((m.bandwidth for m in self.mechanisms), key=bandwidth_rank)

    @property
    def cpus(self) -> int:
        return max(m.cpus for m in self.mechanisms)

    @property
    def duplex(self) -> Optional[Mechanism]:
        return next((m for m in self.mechanisms if m.duplex), None)

    @property
    def replicas(self) -> int:
        return 2 if self.duplex else 1

    def expr(self) -> FtmExpr:
        e: Optional[FtmExpr] = None
        for n in reversed(self.names):
            e = FtmExpr(n, e)
        assert e is not None
        return e

    def __str__(self) -> str:
        return str(self.expr())


def compose(expr: FtmExpr) -> tuple[Optional[Composition], list[str]]:
    """The composition an expression denotes, or None with the reasons it is ill-formed."""
    names = layers(expr)
    problems = [f"unknown mechanism '{n}'" for n in names if n not in LIBRARY]
    if problems:
        return None, problems
    kinds = [LIBRARY[n].layer for n in names]
    for k in LAYER_ORDER:
        if kinds.count(k) > 1:
            which = [n for n in names if LIBRARY[n].layer == k]
            problems.append(f"{' and '.join(which)} are both {_layer_word(k)}; a composition has one at most")
    if not problems and kinds != sorted(kinds, key=LAYER_ORDER.index):
        problems.append(f"'{expr}' nests in the wrong order: SEC goes outside a duplex (PBR, LFR, AD), "
                        "which goes outside TR, e.g. SEC(PBR(TR))")
    return (None, problems) if problems else (Composition(tuple(names)), [])


def _layer_word(kind: str) -> str:
    return {"sec": "security layers", "dup": "duplex patterns", "tr": "time redundancy"}[kind]


def all_compositions() -> list[Composition]:
    """Every well-formed composition: optional SEC × optional duplex × optional TR, not empty."""
    out = []
    for sec in (None, "SEC"):
        for dup in (None, "PBR", "LFR", "AD"):
            for tr in (None, "TR"):
                names = tuple(n for n in (sec, dup, tr) if n is not None)
                if names:
                    out.append(Composition(names))
    return out


def roles(comp: Composition, replica: int) -> list[tuple[str, RoleSpec]]:
    """(layer, role) for each layer of `comp` on replica `replica`, outermost first. Single-replica
    layers play their one role on every replica."""
    return [(m.layer, m.replicas[min(replica, len(m.replicas) - 1)]) for m in comp.mechanisms]
