"""Architectures for the FTM tests: the client/server of paper 000 with any FTM, and the FTM examples."""
from __future__ import annotations

import os
from typing import Optional

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

