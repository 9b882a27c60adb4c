"""A configuration: which components are present, which functionalities are degraded,
which ports are attached to which connector. The architecture (types, modes, rates) is
the `System`; a configuration is the run-time state the six actions change."""
from __future__ import annotations

from dataclasses import dataclass

from reconf_dsl.ir import Component, Functionality, System

FuncId = tuple[str, str]          # (component, functionality)
Role = tuple[str, str, str]       # (connector, component, port)


@dataclass(frozen=True)
class Configuration:
    components: frozenset[str]
    degraded: frozenset[FuncId]
    roles: frozenset[Role]

    @staticmethod
    def initial(system: System) -> "Configuration":
        """The deployed configuration: every component present, every functionality normal,
        every declared attachment in place."""
        roles = frozenset((c.name, r.component, r.port) for c in system.connectors for r in c.roles)
        return Configuration(frozenset(c.name for c in system.components), frozenset(), roles)

    def attached(self, connector: str) -> list[tuple[str, str]]:
        return sorted((comp, port) for conn, comp, port in self.roles if conn == connector)

    def connector_of(self, component: str, port: str) -> list[str]:
        return sorted(conn for conn, comp, p in self.roles if comp == component and p == port)


def functionalities(component: Component) -> list[Functionality]:
    return list(component.functionalities)
