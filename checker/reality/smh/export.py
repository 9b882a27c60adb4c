"""An architecture's deployed configuration as an SMH model file (docs/modes.md#export).

Each component with functionalities is an SMH node whose modes set its `reconf.mode.<f>`
parameters; the system is an SMH system over them whose modes are configurations the checker
proves valid: `__DEFAULT__` (every functionality normal), `DEGRADED` (every one degraded), and per
component, and per functionality of a component with several, that one degraded together with
everything the degradation forces (`settle`, checker/planning/plan.py)."""
from __future__ import annotations

import functools
import json
import re
from dataclasses import dataclass
from typing import Iterable

import yaml

from checker.planning.plan import Goal, settle
from checker.reality.smh import DEFAULT, DEGRADED, DEGRADED_VALUE, NORMAL_VALUE, PARAM
from checker.reality.unique_names import unique
from checker.semantic_model.actions import Snapshot, catalogue, failing_assumptions, is_valid
from checker.semantic_model.config import Configuration, FuncId
from reconf_dsl.ir import Component, Predicate, System

__all__ = ["NodeMode", "SystemMode", "SmhExport", "UnsafeDeployment", "export", "render"]


@dataclass(frozen=True)
class NodeMode:
    name: str
    degraded: frozenset[str]        # the component's functionalities degraded in this mode


@dataclass(frozen=True)
class SystemMode:
    name: str
    degraded: frozenset[FuncId]
    origin: str                     # what the mode stands for (the YAML's comment)
    forced: tuple[tuple[FuncId, str], ...] = ()   # degraded because of the others, and why


@dataclass
class SmhExport:
    system: str                     # the SMH system's name
    components: list[Component]     # the parts, in declaration order
    skipped: list[str]              # components without functionalities: no mode to drive
    nodes: dict[str, list[NodeMode]]
    modes: list[SystemMode]

    def node_modes_of(self, mode: SystemMode) -> dict[str, str]:
        """Per part, the name of its node mode in the system mode `mode`."""
        mine = _by_component(mode.degraded)
        return {c.name: self._names[c.name][mine.get(c.name, frozenset())] for c in self.components}

    def __post_init__(self) -> None:
        self._names = {c: {m.degraded: m.name for m in modes} for c, modes in self.nodes.items()}


class UnsafeDeployment(Exception):
    """The deployed configuration is not valid, so a `__DEFAULT__` of all normal would not be."""

    def __init__(self, failing: list[tuple[str, str, Predicate]]):
        super().__init__(f"{len(failing)} assumptions do not hold")
        self.failing = failing


def export(system: System, degrade_unsafe: bool = False) -> SmhExport:
    """The SMH modes of `system`; an unsafe one is refused unless `degrade_unsafe`, whose
    `__DEFAULT__` then degrades what must be degraded for it to be valid."""
    config = Configuration.initial(system)
    comps = [c for c in system.components if c.functionalities]
    base = settle(system, Goal(config.components, config.roles))
    if base.degraded and not degrade_unsafe:
        raise UnsafeDeployment(failing_assumptions(system, config))
    taken: set[str] = set()
    default_origin = ("every functionality normal: the deployed configuration" if not base.degraded else
                      "the deployed configuration is unsafe: every functionality normal that can be")
    modes = [SystemMode(unique(DEFAULT, taken), base.degraded, default_origin, base.why),
             SystemMode(unique(DEGRADED, taken), _funcs(comps), "every functionality degraded (assumes nothing)")]
    for c in comps:
        own = frozenset((c.name, f.name) for f in c.functionalities)
        names = ", ".join(f.name for f in c.functionalities)
        modes.append(_forced(system, base, own, unique(f"{DEGRADED}_{c.name}", taken),
                             f"component {c.name} degraded ({names})"))
        if len(c.functionalities) > 1:
            for f in c.functionalities:
                modes.append(_forced(system, base, frozenset({(c.name, f.name)}),
                                     unique(f"{DEGRADED}_{c.name}_{f.name}", taken), f"{c.name}.{f.name} degraded"))
    for m in modes:
        if not is_valid(system, Configuration(config.components, m.degraded, config.roles)):
            raise AssertionError(f"system mode {m.name} is not a valid configuration")
    name = unique(system.name, {c.name for c in comps})   # SMH systems and nodes share one namespace
    skipped = [c.name for c in system.components if not c.functionalities]
    groups = [_by_component(m.degraded) for m in modes]
    return SmhExport(name, comps, skipped, {c.name: _node_modes(c, groups) for c in comps}, modes)


def _funcs(comps: Iterable[Component]) -> frozenset[FuncId]:
    return frozenset((c.name, f.name) for c in comps for f in c.functionalities)


def _forced(system: System, base: Goal, seed: frozenset[FuncId], name: str, origin: str) -> SystemMode:
    """`seed` degraded on top of `base`, and whatever that forces: `settle`'s least set, grown
    from the readers of what was just degraded only (a degraded mode assumes nothing, and the
    rest of `base` is valid), so a mode costs its own reach and not the system's size."""
    cat = catalogue(system)
    degraded = set(base.degraded | seed)
    forced: dict[FuncId, str] = {}
    changed = {c for c, _ in seed}
    while changed:
        st = Snapshot(cat, Configuration(base.components, frozenset(degraded), base.roles))
        readers = st.readers(conn for c in changed for conn, _ in st.attached_outputs(c))
        new = [(c, f, a) for c, f, a in st.unsafe(readers & base.components) if (c, f) not in degraded]
        for c, f, a in new:
            forced.setdefault((c, f), f"it assumes {a}, which no longer holds")
            degraded.add((c, f))
        changed = {c for c, _, _ in new}
    return SystemMode(name, frozenset(degraded), origin, tuple(sorted(forced.items())))


def _node_modes(c: Component, groups: list[dict[str, frozenset[str]]]) -> list[NodeMode]:
    """__DEFAULT__, DEGRADED, one per functionality when there are several, then every other
    combination a system mode needs (named after its functionalities, in declaration order)."""
    order = [f.name for f in c.functionalities]
    taken: set[str] = set()
    out = [NodeMode(unique(DEFAULT, taken), frozenset()), NodeMode(unique(DEGRADED, taken), frozenset(order))]
    if len(order) > 1:
        out += [NodeMode(unique(f"{DEGRADED}_{f}", taken), frozenset({f})) for f in order]
    seen = {n.degraded for n in out}
    for g in groups:                       # each system mode's degraded functionalities, by component
        mine = g.get(c.name, frozenset())
        if mine not in seen:
            seen.add(mine)
            label = "_".join(f for f in order if f in mine)
            out.append(NodeMode(unique(f"{DEGRADED}_{label}", taken), mine))
    return out


def _by_component(degraded: frozenset[FuncId]) -> dict[str, frozenset[str]]:
    out: dict[str, set[str]] = {}
    for c, f in degraded:
        out.setdefault(c, set()).add(f)
    return {c: frozenset(fs) for c, fs in out.items()}


# --- the YAML text -------------------------------------------------------------------------

_PLAIN = re.compile(r"[^\W\d][\w.]*")


@functools.lru_cache(maxsize=4096)
def scalar(text: str) -> str:
    """`text` as a YAML scalar: plain when it reads back as itself, else double-quoted."""
    if _PLAIN.fullmatch(text) and yaml.safe_load(text) == text:
        return text
    return json.dumps(text, ensure_ascii=False)


def render(exp: SmhExport, system: System) -> str:
    """The model file, commented: which component and functionalities each mode comes from."""
    files = ", ".join(system.files) or "?"
    lines = [f"# SMH model file (ROS 2 system_modes) of the reconf architecture {system.name} ({files}),",
             "# written by `reconf modes export`. Each component is a node whose modes set its",
             "# reconf.mode.<functionality> parameters (docs/control-interface.md); every mode of the",
             "# system is a configuration reconf's checker proves safe. The mode manager switches the",
             "# parts in no particular order: `reconf plan` orders the steps of a change (docs/modes.md).",
             "---", ""]
    if exp.skipped:
        lines += [f"# not parts (no functionality, so no mode): {', '.join(exp.skipped)}", ""]
    lines += _system_lines(exp)
    for c in exp.components:
        lines += ["", f"# reconf component {c.name} ({c.span})"] + _node_lines(c, exp.nodes[c.name])
    return "\n".join(lines) + "\n"


def _system_lines(exp: SmhExport) -> list[str]:
    plain = all(scalar(c.name) == c.name for c in exp.components)   # SMH's own layout: a name a line
    parts = " ".join(c.name for c in exp.components)
    shown = [f"      {c.name}" for c in exp.components] if plain else [f"      {scalar(parts)}"]
    out = [f"{scalar(exp.system)}:", "  ros__parameters:", "    type: system", "    parts:", *shown, "    modes:"]
    for m in exp.modes:
        out.append(f"      # {m.origin}")
        out += [f"      #   forces {c}.{f}: {why}" for (c, f), why in m.forced]
        out.append(f"      {scalar(m.name)}:")
        out += [f"        {scalar(c)}: {scalar('active.' + n)}" for c, n in exp.node_modes_of(m).items()]
    return out


def _node_lines(c: Component, modes: list[NodeMode]) -> list[str]:
    out = [f"{scalar(c.name)}:", "  ros__parameters:", "    type: node", "    modes:"]
    for m in modes:
        what = ("every functionality normal" if not m.degraded else
                "every functionality degraded" if len(m.degraded) == len(c.functionalities) else
                ", ".join(f.name for f in c.functionalities if f.name in m.degraded) + " degraded")
        # reconf.mode.<f> nested, as `ros2 param dump` writes parameters: every parser reads it so
        out += [f"      # {what}", f"      {scalar(m.name)}:", "        ros__parameters:",
                f"          {PARAM.split('.')[0]}:", f"            {PARAM.split('.')[1]}:"]
        out += [f"              {scalar(f.name)}: {DEGRADED_VALUE if f.name in m.degraded else NORMAL_VALUE}"
                for f in c.functionalities]
    return out
