"""Real nodes for the bundled examples, written with the Component API (docs/runtime.md).
Each factory returns a Component; `reconf-node reconf_ros.demo.chatter:talker` runs one, and
the `run` lines of examples/*.arch name them. tests/ros holds each to its example's model."""
