"""What FTM nodes exchange: JSON documents in `std_msgs/msg/String` (docs/ftm.md#running).

A request inside a mechanism is `{"rid", "body", ...}`: `rid` the proxy's request id, `body`
the client's operation (`{"op": "compute", "x": 3}`); layers add their own keys. A result is
`{"rid", "reply", "state"?}`. The application answers `{"tag", "ops": [...]}` with
`{"tag", "results": [...]}`.
"""
from __future__ import annotations

import json
import time
from typing import Any, Optional

from ..api import Component, Functionality, Input, Output, Port

__all__ = ["pack", "unpack", "result_of", "Ports", "now"]


def pack(doc: dict[str, Any]) -> str:
    return json.dumps(doc, separators=(",", ":"), sort_keys=True)


def unpack(msg: Any, need: str = "") -> Optional[dict[str, Any]]:
    """The document a message carries, or None when it is not one (a model-driven default) or
    lacks the key `need`."""
    try:
        doc = json.loads(msg.data)
    except (ValueError, AttributeError, TypeError):
        return None
    return doc if isinstance(doc, dict) and (not need or need in doc) else None


def result_of(doc: dict[str, Any], keys: tuple[str, ...] = ("rid", "reply", "state")) -> dict[str, Any]:
    """A result's own keys of a document that carries more (the request, a layer's context)."""
    return {k: doc[k] for k in keys if k in doc}


def now() -> float:
    return time.monotonic()


class Ports:
    """An FTM node's ports by name, with `send(port, doc)` and the functionality's current mode."""

    def __init__(self, comp: Component, fn: Functionality) -> None:
        self.comp, self.fn = comp, fn
        self.by_name: dict[str, Port] = {p.name: p for p in comp.ports}

    def has(self, name: str) -> bool:
        return name in self.by_name

    def input(self, name: str) -> Input:
        p = self.by_name[name]
        assert isinstance(p, Input)
        return p

    def output(self, name: str) -> Output:
        p = self.by_name[name]
        assert isinstance(p, Output)
        return p

    def send(self, name: str, doc: dict[str, Any]) -> bool:
        out = self.output(name)
        return out.write(out.new(data=pack(doc)))

    def quiet(self) -> None:
        """No generic publishing: the behaviour writes; the modes keep their guarantees (the model)."""
        for mode in (self.fn.normal, self.fn.degraded):
            mode.callback, mode.rate = None, None

    @property
    def normal(self) -> bool:
        node = self.comp.node
        return node is not None and node.modes.get(self.fn.name) == "normal"
