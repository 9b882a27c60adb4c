"""Architectures for the FTM tests: the client/server of paper 000 with any FTM, and the FTM examples;
the shape a transition's plan has (docs/soundness.md#prepare-first-clean-up-last)."""
from __future__ import annotations

import os
from typing import Any, Optional

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(ROOT, "examples", "ftm")


def client_server(ftm: Optional[str], faults: str = "crash", application: str = "deterministic, state_access",
                  resources: str = "", hosts: str = "master, slave") -> str:
    """The paper's client/server, with `ftm` (None: unprotected) and the given (F, A, R)."""
    lines = ["system client_server", "message Reply = std_msgs/msg/String",
             "host client_site { cpus: 1 }", "host master { cpus: 1 bandwidth: high }",
             "host slave { cpus: 1 bandwidth: high }", "component server {"]
    if faults:
        lines.append(f"  faults {faults}")
    if application:
        lines.append(f"  application {application}")
    if resources:
        lines.append(f"  resources {{ {resources} }}")
    if ftm:
        lines.append(f"  ftm {ftm}" + (f" on {hosts}" if hosts else ""))
    lines += ["  output reply: Reply",
              "  functionality serve (reply) criticality 2 {",
              "    normal { reply: Reply @ 10 Hz }", "    degraded { reply: nothing }", "  }", "}",
              "component client {", "  host client_site", "  input reply: Reply @ 10 Hz",
              "  functionality use (reply) {", "    normal { assume Reply @ 10 Hz }", "    degraded { }", "  }", "}",
              "service /compute: Reply @ 10 Hz { server.reply -> client.reply }", ""]
    return "\n".join(lines)


def assert_prepared_first_cleaned_up_last(steps: list[dict[str, Any]]) -> None:
    """The new nodes are created and linked among themselves before anyone degrades; then the
    suspension and the resume; last, the old nodes, cut off from what stays, are taken apart."""
    kinds = [s["action"] for s in steps]
    created = {s["component"] for s in steps if s["action"] == "create"}
    removed = {s["component"] for s in steps if s["action"] == "remove"}
    first = kinds.index("degrade")
    assert kinds[0] == "create" and "create" not in kinds[first:]
    assert all(s["component"] in created for s in steps[:first])
    assert any(s["action"] == "attach" for s in steps[:first])
    resumed = max(i for i, s in enumerate(steps) if s["action"] == "upgrade" and s["component"] not in created)
    assert all(s["component"] in removed for s in steps[resumed + 1:])
    assert not removed or steps[-1]["action"] == "remove"
