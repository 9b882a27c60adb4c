"""`python -m reconf_ros.nodes.ftm.hosts FILE [HOST]`: the components FILE places on HOST (one per
line, space-separated), or every host with its components: to start one process per host with
`reconf-node --arch FILE $(python -m reconf_ros.nodes.ftm.hosts FILE HOST) --deployed FILE`."""
from __future__ import annotations

import sys

from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.loader import load


def by_host(path: str) -> dict[str, list[str]]:
    system = load([path])
    hosts: dict[str, list[str]] = {}
    for comp in system.components:
        hosts.setdefault(comp.host or "-", []).append(comp.name)
    return hosts


def main(argv: list[str]) -> int:
    if not 1 <= len(argv) <= 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    try:
        hosts = by_host(argv[0])
    except (DiagnosticError, OSError) as e:
        print(f"{argv[0]}: {e}", file=sys.stderr)
        return 2
    if len(argv) == 2:
        if argv[1] not in hosts:
            print(f"{argv[0]} places nothing on host {argv[1]!r} (hosts: {', '.join(sorted(hosts))})", file=sys.stderr)
            return 2
        print(" ".join(hosts[argv[1]]))
    else:
        for host, names in sorted(hosts.items()):
            print(f"{host}: {' '.join(names)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
