"""Small architectures in the DSL for the planner tests."""
from __future__ import annotations

from reconf_dsl.ir import System
from reconf_dsl.loader import load_text

TALKER = """
component talker {
  output out: String
  functionality talk (out) {
    normal   { out: String @ 10 Hz }
    degraded { out: nothing }
  }
}
"""

LISTENER = """
component %(name)s {
  input in: String @ 10 Hz
  functionality listen (in) criticality %(crit)d {
    normal   { assume String @ 10 Hz }
    degraded { }
  }
}
"""


def talker_system(single: bool = False, listeners: tuple[tuple[str, int], ...] = (("listener", 1),),
                  second_talker: bool = False) -> System:
    """talker.out → /chatter → listener.in, and the version talker_v2."""
    parts = ["system chatter", "message String = std_msgs/msg/String", TALKER,
             TALKER.replace("component talker", "component talker_v2 replaces talker")]
    if second_talker:
        parts.append(TALKER.replace("component talker", "component backup"))
    parts += [LISTENER % {"name": n, "crit": c} for n, c in listeners]
    pubs = "talker.out" + (", backup.out" if second_talker else "")
    subs = ", ".join(f"{n}.in" for n, _ in listeners)
    parts.append(f"topic /chatter: String @ 10 Hz{' single' if single else ''} {{ {pubs} -> {subs} }}")
    return load_text("\n".join(parts), "chatter.arch")


RELAY = """
component %(name)s {
  input in: String @ 10 Hz
  output out: String
  functionality relay (in, out) criticality %(crit)d {
    normal   { assume String @ 10 Hz  out: String @ 10 Hz }
    degraded { out: %(degraded)s }
  }
}
"""


def ring_system(degraded_still_serves: bool) -> System:
    """a → /ab → b → /ba → a: a cycle of two relays, and the version a_v2."""
    d = "String @ 10 Hz" if degraded_still_serves else "nothing"
    text = "\n".join([
        "system ring", "message String = std_msgs/msg/String",
        RELAY % {"name": "a", "crit": 1, "degraded": d},
        (RELAY % {"name": "a_v2", "crit": 1, "degraded": d}).replace("component a_v2", "component a_v2 replaces a"),
        RELAY % {"name": "b", "crit": 2, "degraded": d},
        "topic /ab: String @ 10 Hz { a.out -> b.in }",
        "topic /ba: String @ 10 Hz { b.out -> a.in }",
    ])
    return load_text(text, "ring.arch")


def chain_system(n: int, single: bool = False, ring: bool = False, serves: tuple[bool, ...] = ()) -> System:
    """r0 → /t0 → r1 → … → r(n-1), each relay reading the previous topic (a source feeds r0,
    or with `ring` the last topic does); the version r0_v2. `serves[i]`: r_i's degraded mode
    still satisfies its topic."""
    parts = ["system chain", "message String = std_msgs/msg/String"]
    if not ring:
        parts.append(TALKER.replace("component talker", "component source"))
    for i in range(n):
        d = "String @ 10 Hz" if i < len(serves) and serves[i] else "nothing"
        parts.append(RELAY % {"name": f"r{i}", "crit": 1 + i % 3, "degraded": d})
    parts.append((RELAY % {"name": "r0_v2", "crit": 1, "degraded": "nothing"}).replace(
        "component r0_v2", "component r0_v2 replaces r0"))
    first = f"r{n - 1}.out" if ring else "source.out"
    s = " single" if single else ""
    parts.append(f"topic /in: String @ 10 Hz{s} {{ {first} -> r0.in }}")
    for i in range(n - 1):
        parts.append(f"topic /t{i}: String @ 10 Hz{s} {{ r{i}.out -> r{i + 1}.in }}")
    return load_text("\n".join(parts), "chain.arch")
