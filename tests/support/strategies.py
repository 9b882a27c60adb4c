"""Hypothesis strategies for documents in the DSL (syntax-level: names need not resolve)."""
from __future__ import annotations

from fractions import Fraction

from hypothesis import strategies as st

from reconf_dsl import ir

KEYWORDS = ["sig", "run", "pred", "open", "fun", "all", "some", "none", "lambda", "class", "def", "import",
            "normal", "degraded", "input", "output", "topic", "service", "component", "system", "single"]
# `nothing` cannot be a name (`x: nothing` means no data); `assume` cannot name a guaranteed port.
RESERVED = {"nothing", "assume"}

names = st.one_of(
    st.from_regex(r"[a-z_][a-z0-9_]{0,8}", fullmatch=True),
    st.sampled_from(KEYWORDS),
    st.sampled_from(["ünïcode", "Ωmega", "snake_case_9"]),
).filter(lambda n: n not in RESERVED)
ros_names = st.lists(st.from_regex(r"[a-z][a-z0-9_]{0,5}", fullmatch=True), min_size=1, max_size=3).map(
    lambda parts: "/" + "/".join(parts))
ros_types = st.tuples(names, names).map(lambda t: f"{t[0]}_msgs/msg/{t[1].capitalize() or 'T'}")

rate_values = st.one_of(st.integers(1, 5000).map(Fraction),
                        st.decimals(min_value="0.01", max_value="999", places=2).map(lambda d: Fraction(str(d))))
rates = st.builds(ir.Rate, rate_values.filter(lambda v: v > 0), st.sampled_from(sorted(ir.UNITS)))
data_preds = st.builds(ir.Predicate, names, st.none() | rates)
preds = st.one_of(data_preds, st.just(ir.NOTHING))


param_values = st.one_of(st.booleans(), st.integers(-2 ** 63, 2 ** 63 - 1),
                         st.floats(allow_nan=False, allow_infinity=False),
                         st.text(alphabet=st.characters(blacklist_categories=("Cs", "Cc")), max_size=8))
effects = st.one_of(st.builds(ir.Effect, st.sampled_from(["deactivate", "hold"])),
                    st.builds(ir.Effect, st.just("set"), st.lists(names, min_size=1, max_size=3).map(".".join),
                              param_values))
ros_nodes = st.builds(ir.RosNode, names, st.booleans(),
                      st.lists(st.builds(ir.NodeTopic, names, names | ros_names), max_size=3).map(tuple),
                      st.lists(st.builds(ir.NodeMode, names, st.sampled_from(["normal", "degraded"]),
                                         st.lists(effects, min_size=1, max_size=3).map(tuple)),
                               max_size=3).map(tuple))


@st.composite
def components(draw: st.DrawFn) -> ir.Component:
    port_names = draw(st.lists(names, max_size=4, unique=True))
    ports = []
    for n in port_names:
        if draw(st.booleans()):
            asm = draw(data_preds)
            ports.append(ir.Port(n, "input", asm.message or "", asm))
        else:
            ports.append(ir.Port(n, "output", draw(names)))
    funcs = []
    for fname in draw(st.lists(names, max_size=2, unique=True)):
        fports = tuple(draw(st.lists(st.sampled_from(port_names), unique=True))) if port_names else ()

        def mode(kind: str) -> ir.Mode:
            return ir.Mode(kind, tuple(draw(st.lists(data_preds, max_size=2))),  # type: ignore[arg-type]
                           tuple(ir.Guarantee(p, draw(preds)) for p in draw(st.lists(names, max_size=2))))
        funcs.append(ir.Functionality(fname, fports, mode("normal"), mode("degraded"), draw(st.integers(0, 9))))
    expr = draw(st.recursive(st.builds(ir.FtmExpr, st.sampled_from(["PBR", "LFR", "TR", "AD", "SEC"])),
                             lambda inner: st.builds(ir.FtmExpr, st.sampled_from(["PBR", "SEC"]), inner),
                             max_leaves=3))
    ftm = draw(st.none() | st.builds(ir.FtmDecl, st.just(expr), st.lists(names, max_size=2).map(tuple)))
    return ir.Component(
        draw(names), tuple(ports), tuple(funcs),
        run=draw(st.none() | st.text(alphabet=st.characters(blacklist_categories=("Cs", "Cc")), max_size=20)),
        host=draw(st.none() | names), replaces=draw(st.none() | names),
        faults=tuple(draw(st.lists(names, max_size=2))), application=tuple(draw(st.lists(names, max_size=2))),
        resources=tuple(ir.ResourceSetting(k, v) for k, v in draw(st.lists(
            st.tuples(names, names | st.integers(0, 64).map(str)), max_size=2))),
        ftm=ftm, node=draw(st.none() | ros_nodes),
        takes=tuple(draw(st.lists(st.builds(ir.Take, st.sampled_from(ir.ACTIONS), rate_values.filter(lambda v: v >= 0),
                                            st.sampled_from(["s", "ms"])), max_size=3))))


portrefs = st.builds(ir.PortRef, names, names)
connectors = st.builds(ir.Connector, names | ros_names, st.sampled_from(["topic", "service"]), data_preds,
                       st.booleans(), st.lists(portrefs, max_size=3).map(tuple),
                       st.lists(portrefs, max_size=6).map(tuple)).map(
    lambda c: c if c.kind == "topic" or not c.single else ir.Connector(c.name, c.kind, c.guarantee, False,
                                                                       c.publishers, c.subscribers))
items = st.one_of(
    st.builds(ir.MessageType, names, ros_types),
    st.builds(ir.EnvGuarantee, names, data_preds),
    st.builds(ir.Host, names, st.lists(st.builds(ir.ResourceSetting, names, names), max_size=2).map(tuple)),
    st.builds(ir.Include, st.from_regex(r"[a-z]{1,6}(/[a-z]{1,6})?\.arch", fullmatch=True)),
    components(), connectors,
)
documents = st.builds(ir.Document, st.just("gen.arch"), st.none() | names, st.lists(items, max_size=6).map(tuple))
