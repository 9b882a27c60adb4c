"""Interoperation with the ROS 2 `system_modes` package (SMH model files): `export` writes one from
an architecture, `read` and `to_arch` make an architecture's starting point from one. The mapping
in both directions, and what does not map, is docs/modes.md."""
from __future__ import annotations

DEFAULT = "__DEFAULT__"        # the mode SMH requires of every part, defined first
DEGRADED = "DEGRADED"          # every functionality degraded (node) / every part degraded (system)
PARAM = "reconf.mode."         # the control interface's parameter per functionality (docs/control-interface.md)
NORMAL_VALUE, DEGRADED_VALUE = "normal", "degraded"
STATES = ("unconfigured", "inactive", "active", "finalized")   # lifecycle primary states SMH names
