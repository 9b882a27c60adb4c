"""The DDS set-up of reconf's live systems: Fast DDS over UDP on the loopback (docs/runtime.md#dds).

`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` makes rmw_fastrtps give every participant shared
memory and UDP transports of its own choosing; `SYSTEM_DEFAULT` leaves the participant to
Fast DDS's default profile, which `loopback_udp.xml` makes UDP on 127.0.0.1 alone."""
from __future__ import annotations

from pathlib import Path

PROFILE = Path(__file__).resolve().with_name("loopback_udp.xml")


def loopback_env() -> dict[str, str]:
    """What a ROS 2 process's environment needs to use the profile (with rmw_fastrtps_cpp)."""
    return {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT", "FASTDDS_DEFAULT_PROFILES_FILE": str(PROFILE)}


def network_env() -> dict[str, str]:
    """What a ROS 2 process's environment needs to talk to other hosts (docs/hosts.md#dds-across-hosts):
    Fast DDS's own discovery (multicast on the hosts' network) over UDP alone, no shared memory
    (whose port checks stall a process's readers, see above), and none of the loopback profile."""
    return {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT", "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4"}
