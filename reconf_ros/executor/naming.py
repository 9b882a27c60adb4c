"""Which node is a component's, and under what name a new one starts (docs/executor.md#names).

A component and its node share a name, except a new version `X@new`, which runs beside X as
`X_2` (the first free name) and declares X in its status, and a component whose node a later
plan finds elsewhere by that declaration."""
from __future__ import annotations

from typing import Any, Iterable, Optional

from .status import find_node


class Names:
    """The node of each component of one plan: its own name, or where `locate` found it or a
    create put it (`placed`)."""

    def __init__(self, rt: Any, renames: dict[str, str], components: Iterable[str], fingerprint: str) -> None:
        self.rt, self.renames, self.fingerprint = rt, renames, fingerprint
        self.components = set(components)
        self.placed: dict[str, str] = {}        # component -> its node's name, where not its own

    def declared(self, comp: str) -> str:
        """The component's name in its architecture, which its node declares in its status."""
        return self.renames.get(comp, comp)

    def is_version(self, comp: str) -> bool:
        """A new version `X@new` of a component X of the same plan (docs/executor.md#names)."""
        return comp in self.renames and self.renames[comp] in self.components

    def node_name(self, comp: str) -> str:
        """The component's node's name: its own, or where `locate` found it or a create put it;
        a new version not yet found, or a component whose name a new version's node has, has
        none ("X@new" and "X@elsewhere" are never a node's name)."""
        return self.placed.get(comp) or (comp if self.is_version(comp) else self.declared(comp))

    def fqn(self, comp: str) -> str:
        return f"{self.rt.namespace}/{self.node_name(comp)}"

    def connector(self, conn: str) -> str:
        """A connector's name on the wire (a new version's is its name in the new architecture)."""
        return self.renames.get(conn, conn)

    def created_mark(self, comp: str) -> str:
        """What a process a plan's create started shows as `created` in its status."""
        return f"{self.fingerprint} {comp}"

    def locate(self, comps: Iterable[str], graph: Optional[set[str]] = None) -> None:
        """Find the nodes not under their components' names, by their statuses: a new version by
        the mark of the plan step that started it, any other component by the component its
        node declares (a node a plan started as `X@new` declares X and runs on as X). `graph`:
        the nodes, when the caller has just read them."""
        graph, ns = (set(self.rt.nodes()) if graph is None else graph), self.rt.namespace
        mine = {st.get("created", ""): fqn for fqn, st in self.rt.statuses.items() if fqn in graph}
        claimed = {f"{ns}/{n}" for n in self.placed.values()} | \
            {mine[self.created_mark(c)] for c in self.components if self.is_version(c) and self.created_mark(c) in mine}
        for c in sorted(comps, key=lambda c: not self.is_version(c)):     # versions first: they claim
            if c in self.placed:
                continue
            if self.is_version(c):
                found = mine.get(self.created_mark(c))
            else:
                found = find_node(self.fqn(c), self.declared(c), graph, self.rt.statuses, claimed)
                if found == self.fqn(c):
                    continue
                if found is None and self.fqn(c) in claimed:
                    self.placed[c] = f"{self.declared(c)}@elsewhere"    # its name is a new version's node
            if found is not None:
                self.placed[c] = found.rsplit("/", 1)[1]
                claimed.add(found)

    def fresh(self, comp: str) -> str:
        """A node name for a new version: its component's name if no node has it, else the first
        free `<name>_<k>`."""
        base, ns = self.declared(comp), self.rt.namespace
        taken = set(self.rt.nodes()) | {f"{ns}/{n}" for n in self.placed.values()}
        k, name = 2, base
        while f"{ns}/{name}" in taken:
            name, k = f"{base}_{k}", k + 1
        return name
