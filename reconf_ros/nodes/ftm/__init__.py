"""The FTM nodes of paper 000 on reconf_ros: behaviours for the components `reconf ftm expand`
makes (docs/ftm.md#running).

A model-driven node (`reconf-node --arch EXPANDED NAME`, `reconf_ros.nodes.generic`) whose
functionality is one of Table II's behaviours gets that behaviour here instead of the generic
publisher: `install` looks its functionality up in `BEHAVIOURS`, one row per name the
expansion gives (checker.ftm.library and checker.ftm.expand are the source of the names; a
test holds this table to them).
"""
from __future__ import annotations

from typing import Callable, Optional

from reconf_dsl.ir import System

from ..api import Component, Input
from . import detect, pipeline, sec
from .wire import Ports

__all__ = ["BEHAVIOURS", "install"]

Installer = Callable[[Component, Ports, System], object]
# None: the model-driven node's own publisher is the behaviour


def _sec(comp: Component, ports: Ports, system: System) -> object:
    """cipher_sign and decipher_check run on both sides of the channel."""
    client = "__sec_client_" in comp.name
    if ports.fn.name == "cipher_sign":
        return (sec.ClientCipher if client else sec.ServerCipher)(comp, ports, system)
    return (sec.ClientDecipher if client else sec.ServerDecipher)(comp, ports, system)


BEHAVIOURS: dict[str, Optional[Installer]] = {
    "relay": pipeline.Proxy,
    "handle": pipeline.Protocol,
    "pass_request": pipeline.Before,
    "forward_request": pipeline.Before,
    "handle_request": pipeline.Before,
    "save_restore_state": pipeline.Before,
    "compute": pipeline.Proceed,
    "checkpoint": pipeline.After,
    "update_state": pipeline.After,
    "notify": pipeline.After,
    "handle_notification": pipeline.After,
    "compare": pipeline.After,
    "assert_result": pipeline.After,
    "cipher_sign": _sec,
    "decipher_check": _sec,
    "certify": sec.CertificationAuthority,
    "heartbeat": detect.Heartbeat,
    "detect": detect.Detector,
    "recover": detect.Recovery,
}


def install(comp: Component, system: System) -> bool:
    """Give `comp` its FTM behaviour if its one functionality is an FTM role; False otherwise."""
    if len(comp.functionalities) != 1 or "__" not in comp.name:
        return False
    fn = comp.functionalities[0]
    if fn.name not in BEHAVIOURS:
        return False
    make = BEHAVIOURS[fn.name]
    for port in comp.ports:
        port.durable = port.alias == "FtmCert"      # a late reader needs the certificate, never old requests
        if isinstance(port, Input) and fn.name != "detect":
            port.on_demand = True                   # results come as fast as requests are made
    comp.lean = True    # many nodes, a message per hop per request: the executor's cost matters
    if make is not None:
        ports = Ports(comp, fn)
        ports.quiet()
        make(comp, ports, system)
    return True
