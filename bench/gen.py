"""Synthetic architectures for benchmarks: N components in a chosen shape.

Shapes:
  chain  each component reads 1-3 outputs of the one before it
  tree   each component reads 1-3 outputs of its parent (branching 3)
  dag    each component reads 1-3 outputs of random earlier components (seeded);
         a quarter of them also read the hub
  fanin  half the components publish into one hub (redundant publishers on the
         hub's input topics); the hub fans out to every other component
  cycle  rings of 3-12 components, each reading the previous one around the ring;
         each ring's first member also reads the ring before it

Every component has 1-3 outputs, 0-3 inputs (only sources have none: they assume an
environment guarantee instead), and one or two functionalities with a normal and a
degraded mode. Rates are written as Hz, kHz and periods (ms, s), and are consistent:
publisher guarantee >= topic guarantee >= input assumption >= functionality assumption.
One component in five also publishes a backup on a topic someone else already
publishes on. The generated system is safe; with `unsafe=True` exactly one input asks
for twice the rate its topic guarantees, so the functionalities reading it are unsatisfied.

    python -m bench.gen --shape dag --n 1000 --seed 3 -o dag.arch [--unsafe] [--version]
"""
from __future__ import annotations

import argparse
import random
import sys
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Optional

SHAPES = ("chain", "tree", "dag", "fanin", "cycle")

# Message types carried on topics; environment types are disjoint from them, so an
# environment guarantee never masks a topic that falls short.
TOPIC_MESSAGES = {
    "String": "std_msgs/msg/String",
    "Image": "sensor_msgs/msg/Image",
    "LaserScan": "sensor_msgs/msg/LaserScan",
    "Odometry": "nav_msgs/msg/Odometry",
    "Twist": "geometry_msgs/msg/Twist",
    "PointCloud2": "sensor_msgs/msg/PointCloud2",
    "Pose": "geometry_msgs/msg/Pose",
    "JointState": "sensor_msgs/msg/JointState",
}
ENV_MESSAGES = {
    "Imu": "sensor_msgs/msg/Imu",
    "NavSatFix": "sensor_msgs/msg/NavSatFix",
    "Temperature": "sensor_msgs/msg/Temperature",
}
# (name, guarantee the environment gives, what a functionality assumes of it)
ENVIRONMENT = (
    ("imu", "Imu @ 200 Hz", "Imu @ 100 Hz"),
    ("gps", "NavSatFix @ 10 Hz", "NavSatFix @ 200 ms"),
    ("thermo", "Temperature @ 1 s", "Temperature @ 0.5 Hz"),
)


@dataclass(frozen=True)
class Tier:
    """Consistent rates for one topic: publisher >= topic >= input >= assumption."""

    publisher: str
    topic: str
    input: str
    assume: str
    topic_hz: Fraction


TIERS = (
    Tier("20 Hz", "10 Hz", "100 ms", "5 Hz", Fraction(10)),
    Tier("50 ms", "10 Hz", "10 Hz", "200 ms", Fraction(10)),
    Tier("1 kHz", "500 Hz", "2 ms", "0.2 kHz", Fraction(500)),
    Tier("100 Hz", "50 Hz", "20 ms", "25 Hz", Fraction(50)),
    Tier("2 kHz", "1 kHz", "1 ms", "500 Hz", Fraction(1000)),
    Tier("1 s", "0.5 Hz", "2 s", "0.25 Hz", Fraction(1, 2)),
    Tier("30 Hz", "30 Hz", "30 Hz", "15 Hz", Fraction(30)),
)


@dataclass
class Topic:
    name: str
    message: str
    tier: Tier
    publishers: list[tuple[str, str]] = field(default_factory=list)
    subscribers: list[tuple[str, str]] = field(default_factory=list)
    single: bool = False


@dataclass
class Comp:
    name: str
    outputs: list[tuple[str, str]] = field(default_factory=list)  # (port, topic)
    inputs: list[tuple[str, str]] = field(default_factory=list)   # (port, topic)
    env: Optional[int] = None                                     # index into ENVIRONMENT
    criticality: int = 1
    host: int = 0


@dataclass
class Model:
    name: str
    comps: list[Comp]
    topics: dict[str, Topic]
    overrides: dict[tuple[str, str], str] = field(default_factory=dict)  # (comp, input) -> assumption


def hub_component(shape: str, n: int) -> str:
    """A component many others depend on: the one to `replace` in benchmarks."""
    _check(shape, n)
    if shape == "fanin":
        return "hub"
    if shape == "chain":
        return _name(n // 2, n)
    if shape == "dag":
        return _name(_dag_hub(n), n)
    return _name(0, n)  # tree: the root; cycle: the first ring's head


def _check(shape: str, n: int) -> None:
    if shape not in SHAPES:
        raise ValueError(f"unknown shape {shape!r}; one of {', '.join(SHAPES)}")
    if n < 3:
        raise ValueError("n must be at least 3")


def _name(i: int, n: int) -> str:
    return f"c{i}"


def _dag_hub(n: int) -> int:
    return max(1, n // 10)


def _preds(shape: str, n: int, rng: random.Random, n_out: list[int]) -> list[list[tuple[int, int]]]:
    """For every component, the (component, output index) pairs it reads."""
    preds: list[list[tuple[int, int]]] = [[] for _ in range(n)]

    def take(j: int, src: int, k: int) -> None:
        outs = rng.sample(range(n_out[src]), min(k, n_out[src]))
        preds[j].extend((src, o) for o in outs)

    if shape == "chain":
        for j in range(1, n):
            take(j, j - 1, rng.randint(1, 3))
    elif shape == "tree":
        for j in range(1, n):
            take(j, (j - 1) // 3, rng.randint(1, 3))
    elif shape == "dag":
        hub = _dag_hub(n)
        for j in range(1, n):
            srcs = rng.sample(range(j), min(j, rng.randint(1, 3)))
            if j > hub and hub not in srcs and rng.random() < 0.25:
                srcs[0] = hub
            for s in srcs:
                preds[j].append((s, rng.randrange(n_out[s])))
    elif shape == "cycle":
        start = 0
        prev_ring: Optional[range] = None
        while start < n:
            size = min(rng.randint(3, 12), n - start)
            if n - start - size < 3:
                size = n - start
            ring = range(start, start + size)
            for idx, j in enumerate(ring):
                before = ring[idx - 1]  # wraps around: the ring's last feeds its first
                take(j, before, rng.randint(1, 2))
            if prev_ring is not None:
                s = rng.choice(prev_ring)
                preds[start].append((s, rng.randrange(n_out[s])))
            prev_ring = ring
            start += size
    return preds


def _backs_up(i: int) -> bool:
    """Whether component i also publishes, as a backup, on a topic someone else publishes on."""
    return i % 5 == 3


def build(shape: str, n: int, seed: int = 0, unsafe: bool = False) -> Model:
    _check(shape, n)
    rng = random.Random(f"{shape}/{n}/{seed}")
    names = [_name(i, n) for i in range(n)]
    if shape == "fanin":
        return _build_fanin(n, rng, unsafe)
    n_out = [rng.randint(1, 2) if _backs_up(i) else rng.randint(1, 3) for i in range(n)]
    comps = [Comp(names[i], criticality=rng.randint(1, 3), host=i % 4) for i in range(n)]
    topics: dict[str, Topic] = {}
    msg_names = list(TOPIC_MESSAGES)
    for i, c in enumerate(comps):
        for k in range(n_out[i]):
            t = Topic(f"/{c.name}/o{k}", rng.choice(msg_names), rng.choice(TIERS))
            t.publishers.append((c.name, f"o{k}"))
            topics[t.name] = t
            c.outputs.append((f"o{k}", t.name))
    preds = _preds(shape, n, rng, n_out)
    for j, c in enumerate(comps):
        for k, (src, o) in enumerate(preds[j]):
            tname = f"/{comps[src].name}/o{o}"
            if any(tn == tname for _, tn in c.inputs):
                continue  # a port has one connector; reading the same topic twice adds nothing
            port = f"i{len(c.inputs)}"
            c.inputs.append((port, tname))
            topics[tname].subscribers.append((c.name, port))
        if not c.inputs or j % 11 == 0:
            c.env = j % len(ENVIRONMENT)
    # Redundant publishers: a backup output on a topic another component already publishes on.
    for j, c in enumerate(comps):
        if not _backs_up(j):
            continue
        for _ in range(5):
            tname = comps[rng.randrange(j)].outputs[0][1]
            if tname not in (tn for _, tn in c.inputs):
                c.outputs.append(("bk", tname))
                topics[tname].publishers.append((c.name, "bk"))
                break
    for t in topics.values():
        t.single = len(t.publishers) == 1 and rng.random() < 0.2
    model = Model(f"bench_{shape}_{n}", comps, topics)
    if unsafe:
        _inject(model, rng)
    return model


def _build_fanin(n: int, rng: random.Random, unsafe: bool) -> Model:
    n_hub_in = 3
    n_hub_out = 3
    n_pub = (n - 1) // 2
    n_sub = n - 1 - n_pub
    topics: dict[str, Topic] = {}
    msgs = list(TOPIC_MESSAGES)
    for k in range(n_hub_in):
        topics[f"/hub/in{k}"] = Topic(f"/hub/in{k}", msgs[k], TIERS[k])
    for k in range(n_hub_out):
        topics[f"/hub/out{k}"] = Topic(f"/hub/out{k}", msgs[3 + k], TIERS[3 + k])
    comps: list[Comp] = []
    for i in range(n_pub):
        c = Comp(f"c{i}", criticality=rng.randint(1, 3), host=i % 4, env=i % len(ENVIRONMENT))
        k = i % n_hub_in
        c.outputs.append(("o0", f"/hub/in{k}"))
        topics[f"/hub/in{k}"].publishers.append((c.name, "o0"))
        if rng.random() < 0.3:  # a second output of its own, that nobody reads yet
            t = Topic(f"/{c.name}/o1", rng.choice(msgs), rng.choice(TIERS))
            t.publishers.append((c.name, "o1"))
            topics[t.name] = t
            c.outputs.append(("o1", t.name))
        comps.append(c)
    hub = Comp("hub", criticality=3, host=0)
    for k in range(n_hub_in):
        hub.inputs.append((f"i{k}", f"/hub/in{k}"))
        topics[f"/hub/in{k}"].subscribers.append(("hub", f"i{k}"))
    for k in range(n_hub_out):
        hub.outputs.append((f"o{k}", f"/hub/out{k}"))
        topics[f"/hub/out{k}"].publishers.append(("hub", f"o{k}"))
    comps.append(hub)
    for i in range(n_pub, n_pub + n_sub):
        c = Comp(f"c{i}", criticality=rng.randint(1, 3), host=i % 4)
        for k in sorted(rng.sample(range(n_hub_out), rng.randint(1, 3))):
            port = f"i{len(c.inputs)}"
            c.inputs.append((port, f"/hub/out{k}"))
            topics[f"/hub/out{k}"].subscribers.append((c.name, port))
        for k in range(rng.randint(1, 2)):
            t = Topic(f"/{c.name}/o{k}", rng.choice(msgs), rng.choice(TIERS))
            t.publishers.append((c.name, f"o{k}"))
            topics[t.name] = t
            c.outputs.append((f"o{k}", t.name))
        comps.append(c)
    for t in topics.values():
        t.single = len(t.publishers) == 1 and rng.random() < 0.2
    model = Model(f"bench_fanin_{n}", comps, topics)
    if unsafe:
        _inject(model, rng)
    return model


def _inject(model: Model, rng: random.Random) -> None:
    """One input asks for twice what its topic guarantees: that topic's rate is too low for it."""
    candidates = []
    for c in model.comps:
        types = [model.topics[t].message for _, t in c.inputs]
        for port, t in c.inputs:
            if types.count(model.topics[t].message) == 1:  # no other input could stand in for it
                candidates.append((c.name, port, t))
    name, port, t = rng.choice(candidates)
    topic = model.topics[t]
    model.overrides[(name, port)] = f"{topic.message} @ {_hz(topic.tier.topic_hz * 2)} Hz"


def _hz(x: Fraction) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{float(x):g}"


def render(model: Model, version_of: Optional[str] = None) -> str:
    out: list[str] = [f"// generated by bench/gen.py: {len(model.comps)} components",
                      f"system {model.name}", ""]
    for m, ros in {**TOPIC_MESSAGES, **ENV_MESSAGES}.items():
        out.append(f"message {m} = {ros}")
    out.append("")
    for name, guarantee, _ in ENVIRONMENT:
        out.append(f"environment {name}: {guarantee}")
    out.append("")
    for h in range(4):
        out.append(f"host h{h} {{ cpus: {2 * (h + 1)} bandwidth: high }}")
    out.append("")
    topics = model.topics
    for c in model.comps:
        _component(out, c, topics, model.overrides, c.name, None)
        if c.name == version_of:
            _component(out, c, topics, model.overrides, f"{c.name}_v2", c.name)
    for t in topics.values():
        single = " single" if t.single else ""
        pubs = [f"{c}.{p}" for c, p in t.publishers]
        subs = [f"{c}.{p}" for c, p in t.subscribers]
        if len(pubs) + len(subs) <= 8:
            out.append(f"topic {t.name}: {t.message} @ {t.tier.topic}{single} "
                       f"{{ {', '.join(pubs)} -> {', '.join(subs)} }}".replace(" ->  }", " -> }"))
        else:
            # One attachment, its lists wrapped: `a -> b -> c` would not read as two.
            out.append(f"topic {t.name}: {t.message} @ {t.tier.topic}{single} {{")
            out.append(",\n".join(f"  {', '.join(pubs[i:i + 8])}" for i in range(0, len(pubs), 8)))
            out.append("  ->")
            out.append(",\n".join(f"  {', '.join(subs[i:i + 8])}" for i in range(0, len(subs), 8)))
            out.append("}")
    out.append("")
    return "\n".join(out)


def _component(out: list[str], c: Comp, topics: dict[str, Topic], overrides: dict[tuple[str, str], str],
               name: str, replaces: Optional[str]) -> None:
    header = f"component {name} replaces {replaces} {{" if replaces else f"component {name} {{"
    out.append(header)
    out.append(f'  run "ros2 run bench_nodes node --ros-args -r __node:={name}"')
    out.append(f"  host h{c.host}")
    for port, t in c.inputs:
        topic = topics[t]
        asm = overrides.get((c.name, port), f"{topic.message} @ {topic.tier.input}")
        out.append(f"  input {port}: {asm}")
    for port, t in c.outputs:
        out.append(f"  output {port}: {topics[t].message}")
    # f0: every input and the first output; f1 (if more outputs): the first input and the rest.
    groups = [(c.inputs, c.outputs[:1], c.env)]
    if len(c.outputs) > 1:
        groups.append((c.inputs[:1], c.outputs[1:], c.env if not c.inputs else None))
    for gi, (ins, outs, env) in enumerate(groups):
        ports = ", ".join(p for p, _ in ins + outs)
        crit = f" criticality {c.criticality}" if gi == 0 else ""
        out.append(f"  functionality f{gi} ({ports}){crit} {{")
        normal = [f"assume {topics[t].message} @ {topics[t].tier.assume}" for _, t in ins]
        if env is not None:
            normal.append(f"assume {ENVIRONMENT[env][2]}")
        normal += [f"{p}: {topics[t].message} @ {topics[t].tier.publisher}" for p, t in outs]
        degraded = [f"{p}: nothing" if k % 2 == 0 else f"{p}: {topics[t].message} @ {topics[t].tier.input}"
                    for k, (p, t) in enumerate(outs)]
        out.append(f"    normal   {{ {'  '.join(normal)} }}")
        out.append(f"    degraded {{ {'  '.join(degraded)} }}")
        out.append("  }")
    out.append("}")


def generate(shape: str, n: int, seed: int = 0, unsafe: bool = False, version: bool = False) -> str:
    """The text of an architecture of `n` components in `shape`.

    With `version=True` a `<hub>_v2 replaces <hub>` component is declared too (same ports
    and modes), for replacement benchmarks; see `hub_component`."""
    model = build(shape, n, seed, unsafe)
    return render(model, hub_component(shape, n) if version else None)


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.gen", description=__doc__.split("\n\n")[0])
    ap.add_argument("--shape", choices=SHAPES, required=True)
    ap.add_argument("--n", type=int, required=True, help="number of components (at least 3)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--unsafe", action="store_true", help="inject one violation: an input's rate is not met")
    ap.add_argument("--version", action="store_true", help="also declare <hub>_v2 replaces <hub>")
    ap.add_argument("-o", "--output", help="file to write (default: standard output)")
    args = ap.parse_args(argv)
    try:
        text = generate(args.shape, args.n, args.seed, args.unsafe, args.version)
    except ValueError as e:
        ap.error(str(e))
    if args.output:
        with open(args.output, "w", encoding="utf-8") as f:
            f.write(text)
        print(f"{args.output}: {args.shape}, {args.n} components, hub {hub_component(args.shape, args.n)}",
              file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
