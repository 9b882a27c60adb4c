"""Fault-tolerance mechanisms (paper 000; docs/ftm.md) on the semantic model of paper 001.

The encoding, in one place:

- `library`: Table I and Table II as data. Five mechanisms in three layers — `sec` (SEC),
  `dup` (the duplex patterns PBR, LFR, AD: two replicas) and `tr` (TR) — and a composition
  is at most one per layer, nested outermost first: `SEC(PBR(TR))`.
- `expand`: a component with `ftm EXPR on h0, h1` becomes the generic computation graph:
  a client `Proxy` in the server's place on its service; per replica and per layer a
  `Protocol`, `Before` and `After`, and in the innermost layer a `Proceed` calling the
  replica's copy of the application; for a duplex, crash detectors and `Recovery`; for
  SEC, the client-side cipher/decipher nodes and the certification authority. Nesting
  replaces an outer Proceed by the inner Protocol. Every node is an ordinary component with
  one functionality (normal/degraded modes, assumptions, guarantees), so `evaluate`, the
  planners and Alloy apply unchanged. Names are valid DSL names: `server__r0_dup_protocol`.
  A degraded Protocol is *suspended*: it queues requests, forwards nothing inwards, and
  still guarantees the reply type (without rate) to the proxy, so no client is refused.
- `select`: (F, A, R) of a component → every composition judged, valid ones ranked by
  resource cost (CPUs, bandwidth, nodes), each other one with the assumptions ruling it out.
- `rules`: `ftm_diagnostics(system)` — RC401–RC407 for `reconf check`, at the span of the
  mechanism whose assumption fails. `alloy_rules` + alloy_model/ftm.als: the same rules in
  Alloy (with property checks), judged on instance modules; tests make them agree.
- `transition`: a change of FTM (or of the file: `plan_ftm_migrate`) is a migration between
  the two expansions, planned by `checker.planning.plan_migrate` (unchanged nodes kept) in
  three parts: suspend the affected protocols, substitute and link, resume.
  Every state of a transition keeps the proxies serving (`Plan.serving`): Alloy checks it.
- `cli`: `reconf ftm select|expand` (`ftm_group`) and `reconf plan transition` (`transition_cmd`).

See docs/ftm.md.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from checker.exports import lazy

if TYPE_CHECKING:
    from checker.ftm.diagnose import ftm_diagnostics
    from checker.ftm.expand import expand, expand_component, to_text
    from checker.ftm.library import LIBRARY, Composition, all_compositions, compose
    from checker.ftm.select import profile, select
    from checker.ftm.transition import plan_ftm_migrate, plan_transition

# loaded on first use (checker.exports.lazy): a check does not import transitions and planning
__all__, __getattr__ = lazy(__name__, {
    "diagnose": ("ftm_diagnostics",),
    "expand": ("expand", "expand_component", "to_text"),
    "library": ("LIBRARY", "Composition", "all_compositions", "compose"),
    "select": ("profile", "select"),
    "transition": ("plan_ftm_migrate", "plan_transition"),
})
