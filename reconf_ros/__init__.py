"""reconf on ROS 2: the Component API (paper 001 §5.2) as lifecycle nodes that implement the
control interface, the assumption monitor, and the plan executor (docs/runtime.md).

Importing this package needs no ROS; `Component.start()` and `reconf-node` do.
"""
from .nodes.api import Component, DeclarationError, Functionality, Input, Output, components_to_arch

__all__ = ["Component", "Functionality", "Input", "Output", "DeclarationError", "components_to_arch"]
