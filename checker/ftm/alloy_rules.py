"""The FTM rules in Alloy: an instance module (one atom per component with an (F, A, R) or an
FTM, one per candidate composition) that `open`s alloy_model/ftm.als, and asks the Analyzer
which compositions are valid for which component. Python's `select.judge` must agree.

Modules are passed in memory (docs/soundness.md#the-alloy-bridge):
{"ftm.als": the shipped rules, "ftm_instance.als": this}.
"""
from __future__ import annotations

from dataclasses import dataclass
from importlib.resources import files
from typing import Optional

from checker.alloy import get_backend
from checker.alloy.bridge import atom_name as atom
from checker.ftm.library import LIBRARY, Composition, all_compositions, compose, layers
from checker.ftm.select import Profile, profile
from codegen.alloy import union
from reconf_dsl import ir

__all__ = ["ftm_rules_text", "instance_text", "AlloyFtmVerdict", "alloy_ftm_verdict", "alloy_profiles"]

MAIN = "ftm_instance.als"
FAULT_ATOMS = {"crash": "Crash", "transient": "Transient", "permanent_value": "PermanentValue",
               "omission": "Omission", "intrusion": "Intrusion"}
APP_ATOMS = {"deterministic": "Deterministic", "state_access": "StateAccess"}
LEVEL_ATOMS = {"nil": "Nil", "low": "Low", "medium": "Medium", "high": "High"}
MAX_INT = 7  # 4-bit integers; any CPU count above 2 means the same to the rules


def ftm_rules_text() -> str:
    return (files("alloy_model") / "ftm.als").read_text(encoding="utf-8")


def _union(parts: list[str], empty: str = "none -> none") -> str:
    """A balanced union (a flat a+b+c+… type-checks in quadratic time); `empty` when none."""

    return union(parts, empty)


def instance_text(profiles: list[Profile], attached: list[Optional[Composition]],
                  written: Optional[list[list[str]]] = None,
                  hosts: Optional[list[int]] = None) -> tuple[str, list[Composition]]:
    """The module judging `profiles` (and the compositions attached to them); with `written`
    (each component's FTM as written, outermost first) and `hosts` (its distinct hosts), also
    which are misnested (RC401) and which duplexes lack two hosts (RC406)."""
    written = written or [[] for _ in profiles]
    hosts = hosts or [MAX_INT for _ in profiles]
    cands = all_compositions()
    lines = ["module ftm_instance", "open ftm", "",
             "abstract sig Cand {}", f"one sig {', '.join(f'C{i}' for i in range(len(cands)))} extends Cand {{}}",
             "abstract sig Comp {}", f"one sig {', '.join(f'K{i}' for i in range(len(profiles)))} extends Comp {{}}",
             ""]
    lines.append("fun members: Cand -> Mech { " + _union(
        [f"C{i} -> ({' + '.join(c.names)})" for i, c in enumerate(cands)]) + " }")
    lines.append("fun faults: Comp -> Fault { " + _union(
        [f"K{k} -> {FAULT_ATOMS[f]}" for k, p in enumerate(profiles) for f in sorted(p.faults)]) + " }")
    lines.append("fun app: Comp -> AppChar { " + _union(
        [f"K{k} -> {APP_ATOMS[a]}" for k, p in enumerate(profiles) for a in sorted(p.application)
         if a in APP_ATOMS]) + " }")
    lines.append("fun bw: Comp -> Level { " + _union(
        [f"K{k} -> {LEVEL_ATOMS[p.bandwidth or 'high']}" for k, p in enumerate(profiles)]) + " }")
    lines.append("fun ncpu: Comp -> Int { " + _union(
        [f"K{k} -> {min(p.cpus if p.cpus is not None else MAX_INT, MAX_INT)}" for k, p in enumerate(profiles)])
        + " }")
    index = {c.names: i for i, c in enumerate(cands)}
    lines.append("fun written: Comp -> Mech -> Mech { " + _union(
        [f"K{k} -> {a} -> {b}" for k, names in enumerate(written) for a, b in zip(names, names[1:])],
        "none -> none -> none") + " }")
    lines.append("fun nhosts: Comp -> Int { " + _union(
        [f"K{k} -> {min(n, MAX_INT)}" for k, n in enumerate(hosts)]) + " }")
    lines.append("fun attached: Comp -> Cand { " + _union(
        [f"K{k} -> C{index[c.names]}" for k, c in enumerate(attached) if c is not None]) + " }")
    lines += ["",
              "fun valid: Comp -> Cand { { k: Comp, c: Cand | validFor[c.members, k.faults, k.app, k.bw, k.ncpu] } }",
              "fun contradicted: set Comp { { k: Comp | some k.attached and k.attached not in k.valid } }",
              "fun misnested: set Comp { { k: Comp | not wellNested[k.written] } }",
              "fun hostless: set Comp { { k: Comp | some k.attached and not enoughHosts[k.attached.members, "
              "k.nhosts] } }",
              "", "run Verdict {} for 4 Int, 0 Probe expect 1", ""]
    return "\n".join(lines), cands


@dataclass(frozen=True)
class AlloyFtmVerdict:
    valid: dict[str, frozenset[str]]     # component → valid compositions, as text
    contradicted: frozenset[str]         # components whose attached FTM is not valid
    seconds: float
    text: str
    misnested: frozenset[str] = frozenset()   # written in the wrong order, or two of a layer
    hostless: frozenset[str] = frozenset()    # a duplex on fewer than two hosts


def alloy_profiles(profiles: dict[str, Profile], attached: dict[str, Optional[Composition]],
                   written: Optional[dict[str, list[str]]] = None,
                   hosts: Optional[dict[str, int]] = None) -> AlloyFtmVerdict:
    """Alloy's judgement of named profiles (and of the composition attached to each, if any;
    of how it is written and on how many hosts, if given)."""

    names = list(profiles)
    text, cands = instance_text([profiles[n] for n in names], [attached.get(n) for n in names],
                                [(written or {}).get(n, []) for n in names],
                                [(hosts or {}).get(n, MAX_INT) for n in names])
    (out,) = get_backend().run({"ftm.als": ftm_rules_text(), MAIN: text}, MAIN, "Verdict")

    valid: dict[str, set[str]] = {n: set() for n in names}
    for k, c in out.eval("valid"):
        valid[names[int(atom(k)[1:])]].add(str(cands[int(atom(c)[1:])]))
    def comps(expr: str) -> frozenset[str]:
        return frozenset(names[int(atom(k)[1:])] for (k,) in out.eval(expr))

    return AlloyFtmVerdict({n: frozenset(v) for n, v in valid.items()}, comps("contradicted"), out.elapsed, text,
                           comps("misnested"), comps("hostless"))


def alloy_ftm_verdict(system: ir.System) -> AlloyFtmVerdict:
    """Every component with an (F, A, R) or an FTM, judged in Alloy."""
    profiles: dict[str, Profile] = {}
    attached: dict[str, Optional[Composition]] = {}
    written: dict[str, list[str]] = {}
    hosts: dict[str, int] = {}
    for c in system.components:
        if c.ftm is None and not (c.faults or c.application or c.resources):
            continue
        profiles[c.name] = profile(system, c)
        attached[c.name] = compose(c.ftm.expr)[0] if c.ftm is not None else None
        if c.ftm is not None:
            names = layers(c.ftm.expr)
            written[c.name] = names if all(n in LIBRARY for n in names) else []
            hosts[c.name] = len(set(c.ftm.hosts))
    if not profiles:
        return AlloyFtmVerdict({}, frozenset(), 0.0, "")
    return alloy_profiles(profiles, attached, written, hosts)
