"""The one table of example architectures, shared by every test layer (parser, checker,
Alloy, planner, codegen). Add an example here and every layer checks it."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Optional

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def path(*parts: str) -> str:
    return os.path.join(ROOT, *parts)


@dataclass(frozen=True)
class Example:
    name: str
    file: str
    safe: bool
    unsatisfied: frozenset[str] = frozenset()   # "component.functionality" whose assumptions fail
    replace: Optional[str] = None               # a component with a declared replacement version
    paper_plan: tuple[str, ...] = ()            # the `paper` strategy's steps, as `describe()` text
    tags: frozenset[str] = field(default_factory=frozenset)


EXAMPLES: list[Example] = [
    Example("chatter", path("examples", "chatter.arch"), True, replace="talker",
            paper_plan=("degrade listener.listen", "detach talker.out from /chatter", "remove talker",
                        "create talker_v2 (all functionalities degraded)", "upgrade talker_v2.talk",
                        "attach talker_v2.out to /chatter", "upgrade listener.listen"),
            tags=frozenset({"paper001"})),
    Example("chatter_slow", path("examples", "chatter_slow.arch"), False, frozenset({"listener.listen"}),
            tags=frozenset({"rate"})),
    Example("chatter_unpublished", path("examples", "chatter_unpublished.arch"), False,
            frozenset({"listener.listen"}), tags=frozenset({"missing-publisher"})),
    Example("robot", path("examples", "robot.arch"), True, tags=frozenset({"paper001", "environment", "include"})),
    Example("robot_blind", path("examples", "robot_blind.arch"), False, frozenset({"motor_controller.control"}),
            tags=frozenset({"missing-publisher", "include"})),
    Example("robot_slow", path("examples", "robot_slow.arch"), False, frozenset({"motor_controller.control"}),
            tags=frozenset({"rate", "period", "include"})),
    Example("redundant", path("examples", "redundant.arch"), True, tags=frozenset({"redundant"})),
    Example("cycle", path("examples", "cycle.arch"), True, tags=frozenset({"cycle", "environment"})),
    Example("chain5", path("examples", "chain5.arch"), True, tags=frozenset({"chain", "environment"})),
    Example("unmodified", path("examples", "unmodified.arch"), True, replace="talker",
            paper_plan=("degrade listener.count", "detach talker.out from /chatter", "remove talker",
                        "create lc_talker (all functionalities degraded)", "upgrade lc_talker.talk",
                        "attach lc_talker.out to /chatter", "upgrade listener.count"),
            tags=frozenset({"unmodified-nodes"})),
    Example("chatter_unmodified", path("examples", "chatter_unmodified.arch"), True,
            tags=frozenset({"unmodified-nodes"})),
    Example("alloy_keywords", path("tests", "good_inputs", "alloy_keywords.arch"), True,
            tags=frozenset({"keywords", "unicode", "ros-names"})),
    Example("dsl_keywords", path("tests", "good_inputs", "dsl_keyword_as_name.arch"), True,
            tags=frozenset({"keywords"})),
]

BY_NAME = {e.name: e for e in EXAMPLES}
