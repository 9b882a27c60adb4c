"""The executor's run, without ROS: a runtime whose statuses a test sets. A step that takes a
publisher away waits for what the staying one sent after the step began (a publisher that
died a moment ago vouches for nothing); SIGINT and SIGTERM stop a run at the step's end, a
second at once; every monitor counts, a created node's from its own start."""
from __future__ import annotations

import json
import os
import signal
import time
from typing import Any, Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from checker.planning import plan_replace
from checker.reports.plan_document import plan_document
from reconf_dsl.loader import load
from reconf_ros.executor.conditions import wire_before
from reconf_ros.executor.context import Context, Interrupts, StepTiming
from reconf_ros.executor.observe import observe
from reconf_ros.executor.run import Executor, counted, in_run
from reconf_ros.executor.run_report import degraded_line
from reconf_ros.executor.runtime import NoControlInterface, StepFailed
from reconf_ros.executor.script import arguments, parse
from reconf_ros.executor.status import ask_text, parse_ask
from tests.examples_table import ROOT


class Runtime:
    """The part of `reconf_ros.executor.runtime.Runtime` the conditions read: statuses, and a
    wait that looks once (the statuses do not change by themselves here)."""

    namespace = ""

    def __init__(self, statuses: dict[str, dict[str, str]]) -> None:
        self.statuses = statuses
        self.asks: list[tuple[float, list[tuple[str, str]]]] = []

    def status(self, fqn: str) -> Any:
        return self.statuses.get(fqn)

    def ask(self, since: float, inputs: Any) -> None:
        self.asks.append((since, list(inputs)))

    def wait(self, cond: Callable[[], bool], seconds: float) -> bool:
        return bool(cond())

    def nodes(self) -> list[str]:
        return sorted(self.statuses)


def context(statuses: dict[str, dict[str, str]], strategy: str = "default") -> Context:
    system = load([os.path.join(ROOT, "examples", "chatter.arch")])
    plan = plan_replace(system, "talker", "talker_v2", strategy=strategy)
    doc = plan_document("replace talker", system, plan, {}, model=True)
    args = arguments(doc).parse_args(["--wire-timeout", "0.1"])
    return Context(doc, args, out=open(os.devnull, "w"), err=open(os.devnull, "w"), rt=Runtime(statuses))


def test_a_publisher_that_died_a_moment_ago_vouches_for_nothing() -> None:
    """Step 4 detaches talker.out: the listener must have received from talker_v2 since the step
    began. It heard from it 0.1 s before (fresh still): not enough."""
    now = time.time()
    listener = {"in.in.fresh": "talker,talker_v2", "in.in.last.talker_v2": f"{now - 0.1:.3f}",
                "in.in.last.talker": f"{now:.3f}", "in.in@/chatter.publishers": "2"}
    ctx = context({"/listener": listener})
    ctx.began = now
    with pytest.raises(StepFailed, match="has received nothing on /chatter from talker_v2 since the step began"):
        wire_before(ctx, ctx.steps[3], ctx.states[3], ctx.states[4])
    listener["in.in.last.talker_v2"] = f"{now + 0.05:.3f}"       # a message sent after the step began
    wire_before(ctx, ctx.steps[3], ctx.states[3], ctx.states[4])
    # each wait first asked the listener for the status that shows it, from the step's start
    assert ctx.rt.asks == [(now, [("/listener", "in")])] * 2


def test_an_upgrade_waits_for_an_input_received_since_the_step_began() -> None:
    """Step 7 of the paper's replace upgrades listener.listen. Its status says "met", but from
    before the step: a node calls a silence a gap only when its timer next looks, so "met" may
    be a silence old. The step waits for a status that shows a message since it began."""
    now = time.time()
    listener = {"wire.listen": "met", "in.in.last.talker_v2": f"{now - 0.18:.3f}"}
    ctx = context({"/listener": listener}, strategy="paper")
    assert (ctx.steps[6].action, ctx.steps[6].component) == ("upgrade", "listener")
    ctx.began = now
    with pytest.raises(StepFailed, match="nothing received on in since the step began"):
        wire_before(ctx, ctx.steps[6], ctx.states[6], ctx.states[7])
    assert ctx.rt.asks == [(now, [("/listener", "in")])]
    listener["in.in.last.talker_v2"] = f"{now + 0.05:.3f}"
    wire_before(ctx, ctx.steps[6], ctx.states[6], ctx.states[7])
    listener["wire.listen"] = "not met: in: nothing received"      # a fresh message, a verdict not met
    with pytest.raises(StepFailed, match="its assumptions are not met on the wire"):
        wire_before(ctx, ctx.steps[6], ctx.states[6], ctx.states[7])


def test_a_first_signal_asks_a_second_stops_at_once() -> None:
    interrupts = Interrupts()
    interrupts.handler(signal.SIGTERM, None)
    assert interrupts.stop and interrupts.by == "SIGTERM" and interrupts.signals == 1
    with pytest.raises(KeyboardInterrupt):
        interrupts.handler(signal.SIGINT, None)


def test_a_manager_client_s_request_stops_a_run_and_is_forgotten_after() -> None:
    interrupts = Interrupts()
    asked = iter(["SIGINT", ""])
    interrupts.poll = lambda: next(asked, "")
    assert interrupts.stop and interrupts.by == "SIGINT"
    interrupts.forget_requests()
    assert not interrupts.stop and interrupts.poll is None      # the manager keeps serving


def test_every_monitor_counts_from_its_own_start() -> None:
    """A node a plan created counts from the baseline taken when it came up."""
    statuses = {"/listener": {"violations": "2"}, "/talker_v2": {"violations": "1"}}
    ctx = context(statuses)
    ctx.baseline = {"listener": 2, "talker_v2": 0}
    assert counted(ctx, 3) == {"talker_v2": 1}
    statuses["/listener"]["violations"] = "3"
    assert counted(ctx, 5) == {"listener": 1, "talker_v2": 1}
    assert ctx.violated == {"talker_v2": 3, "listener": 5}


def test_a_monitor_s_last_violation_is_placed_among_the_steps() -> None:
    """The warning of a run that saw a violation says when the monitor's last one began, as the
    steps' times place it, and why (what its status said)."""
    why = "count: not met: in: last message 0.183 s ago (limit 0.150 s for String @ 10 Hz)"
    statuses = {"/listener": {"violations": "1", "last_violation": f"1000.500 {why}"}}
    ctx = context(statuses)
    ctx.baseline = {"listener": 0}
    ctx.timings = [StepTiming(1, 1000.0, 0.8, True), StepTiming(2, 1000.9, 0.1, True)]
    counted(ctx, 1)
    assert in_run(ctx, ctx.last_violation["listener"]) == f"0.50 s into step 1: {why}"
    assert in_run(ctx, f"1001.250 {why}") == f"0.25 s after step 2: {why}"
    assert in_run(ctx, f"999.000 {why}") == f"before step 1: {why}"


def test_a_whole_run_says_how_long_what_served_was_degraded_next_to_the_plan_s_estimate() -> None:
    """The paper's replace degrades the listener from the end of step 1 to the end of step 7:
    0.90 s by these step times, against the plan's 0.27 s; the default's degrades no one."""
    system = load([os.path.join(ROOT, "examples", "chatter.arch")])
    doc = plan_document("replace talker", system, plan_replace(system, "talker", "talker_v2", strategy="paper"),
                        {}, model=True)
    ctx = Context(doc, arguments(doc).parse_args([]), out=open(os.devnull, "w"), err=open(os.devnull, "w"))
    assert [s.action for s in ctx.steps] == ["degrade", "detach", "remove", "create", "upgrade", "attach", "upgrade"]
    ctx.args.to_step = 7
    begins = [100.0, 100.06, 100.17, 100.3, 100.8, 100.86, 100.9]
    ctx.timings = [StepTiming(i, at, 0.05, True) for i, at in enumerate(begins, 1)]
    assert degraded_line(ctx, 1) == ("degraded on the wire, by the steps' times: listener.listen 0.90 s (plan "
                                     "~0.27 s); 0.90 s in all (plan ~0.27 s)")
    ctx.args.to_step = 6        # part of a plan: its estimate is the whole plan's
    assert degraded_line(ctx, 1) == ""
    assert degraded_line(context({}), 1) == ""                  # (to_step unset: a part, as above)
    default = context({})
    default.args.to_step = len(default.steps)
    default.timings = [StepTiming(i, 100.0 + i, 0.5, True) for i in range(1, len(default.steps) + 1)]
    assert degraded_line(default, 1) == ("degraded on the wire: no functionality that served before the run "
                                         "(the plan expected none)")


def test_a_plan_of_no_step_parses() -> None:
    ctx = context({})
    doc = dict(ctx.doc, plan=dict(ctx.doc["plan"], steps=[], changes=[]))
    assert parse(doc, ["--yes"]).to_step == 0
    with pytest.raises(SystemExit):
        parse(doc, ["--to-step", "2"])


class AnsweringRuntime(Runtime):
    """Every node active; `lacking` answers get_parameters without the parameters asked for."""

    def __init__(self, statuses: dict[str, dict[str, str]], lacking: str) -> None:
        super().__init__(statuses)
        self.lacking = lacking

    def lifecycles(self, fqns: Any) -> dict[str, Any]:
        return {f: "active" for f in fqns}

    def read(self, wanted: dict[str, list[str]]) -> tuple[dict[str, Any], dict[str, Any]]:
        return self.lifecycles(wanted), self.get_many(wanted)

    def get_many(self, wanted: dict[str, list[str]]) -> dict[str, Any]:
        return {f: NoControlInterface(f"{f} does not implement the control interface") if f == self.lacking
                else {n: ("normal" if n.startswith("reconf.mode.") else []) for n in names}
                for f, names in wanted.items()}


def test_a_node_without_the_components_parameters_is_not_taken_for_it() -> None:
    """A node by a component's name that answers without its parameters (another version of it,
    or no reconf node) is observed as not a reconf node: not present, and no run stops on it."""
    ctx = context({"/listener": {}, "/talker": {}})
    ctx.rt = AnsweringRuntime({"/listener": {}, "/talker": {}}, lacking="/talker")
    seen = observe(ctx, ["listener", "talker"])
    assert seen["talker"].lifecycle == "not a reconf node" and not seen["talker"].present
    assert seen["talker"].why == "/talker does not implement the control interface"   # said, as it answered
    assert seen["listener"].present


class DyingRuntime(AnsweringRuntime):
    """`dying` answers get_state, then dies before its parameters are read."""

    def get_many(self, wanted: dict[str, list[str]]) -> dict[str, Any]:
        out = super().get_many(wanted)
        out[self.lacking] = StepFailed(f"{self.lacking}/get_parameters: no answer within 5 s")
        return out


def test_a_node_that_answers_one_call_and_not_the_next_is_unresponsive_not_an_error() -> None:
    """A node killed between its lifecycle state and its parameters (the final check of a run
    whose new node died): read as not answering, with why, never a run ended by a traceback."""
    ctx = context({"/listener": {}, "/talker": {}})
    ctx.rt = DyingRuntime({"/listener": {}, "/talker": {}}, lacking="/talker")
    seen = observe(ctx, ["listener", "talker"])
    assert seen["talker"].lifecycle == "unresponsive" and "no answer within 5 s" in seen["talker"].why
    assert seen["listener"].present


def test_a_failure_outside_a_step_is_reported_as_a_failure(tmp_path: Any) -> None:
    """The start check or the final check failing (a reading that failed, the step's time up)
    ends the run as failed, with a report, as a step's failure does."""
    from reconf_ros.executor.run import Executor
    ctx = context({})
    args = arguments(ctx.doc).parse_args(["--yes", "--report", str(tmp_path / "r.json")])
    run = Executor(ctx.doc, args, out=open(os.devnull, "w"), err=open(os.devnull, "w"),
                   runtime=DyingRuntime({"/listener": {}, "/talker": {}}, lacking="/talker"))
    run.ctx.step = -1
    assert run._failed_outside(StepFailed("the step took longer than --step-timeout")) == 1
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["outcome"] == "failed" and report["reason"].startswith("during the final check: the step took"), report


class AskedRuntime(AnsweringRuntime):
    """Notes which nodes were asked their lifecycle state."""

    asked: set[str] = set()

    def lifecycles(self, fqns: Any) -> dict[str, Any]:
        fqns = list(fqns)
        self.asked = self.asked | set(fqns)
        return super().lifecycles(fqns)


def test_a_node_the_run_saw_finalized_is_absent_and_not_asked_again() -> None:
    """A node alone in its process ends the process half a second after it is finalized, and stays
    in the graph a while, not answering: a reading after its remove must not ask it."""
    ctx = context({"/listener": {}, "/talker": {}})
    ctx.rt = AskedRuntime({"/listener": {}, "/talker": {}}, lacking="")
    ctx.ended.add("talker")
    seen = observe(ctx, ["listener", "talker"])
    assert seen["talker"].lifecycle == "absent" and ctx.rt.asked == {"/listener"}


def test_a_node_whose_lifecycle_services_are_not_seen_yet_is_asked_once_its_parameters_say_it_is_one() -> None:
    """Over a lossy link the graph can show a node's parameter services before its lifecycle ones:
    the reading asks its state once its parameters answer as a reconf node's, and only a node that
    answers without them is taken for one that is not a reconf node."""
    pytest.importorskip("rclpy")
    from lifecycle_msgs.srv import GetState
    from rcl_interfaces.msg import ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters

    from reconf_ros.executor import runtime as real

    class Graph:        # every node's get_parameters seen, no get_state yet
        def count_services(self, name: str) -> int:
            return 0 if name.endswith("/get_state") else 1

    asked: list[list[str]] = []

    def calls(requests: dict[str, Any], repeat: bool = True) -> dict[str, Any]:
        asked.append(sorted(requests))
        out: dict[str, Any] = {}
        for name in requests:
            if name.endswith("/get_state"):
                out[name] = GetState.Response()
                out[name].current_state.label = "active"
            else:           # /talker is a reconf node; /plain answers unset, as an rclcpp node does
                out[name] = GetParameters.Response()
                out[name].values = [ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="normal")
                                    if name.startswith("/talker") else ParameterValue()]
        return out

    rt = object.__new__(real.Runtime)
    rt.node, rt.calls = Graph(), calls  # type: ignore[method-assign]
    rt.GetState, rt.GetParameters, rt.ParameterType = GetState, GetParameters, ParameterType
    states, params = rt.read({"/talker": ["reconf.mode.talk"], "/plain": ["reconf.mode.talk"]})
    assert states["/talker"] == "active" and params["/talker"] == {"reconf.mode.talk": "normal"}
    assert isinstance(states["/plain"], real.NoControlInterface)
    assert asked == [["/plain/get_parameters", "/talker/get_parameters"], ["/talker/get_state"]]


@given(st.floats(min_value=0, max_value=4e9, allow_nan=False),
       st.lists(st.tuples(st.from_regex(r"(/[a-z][a-z0-9_]{0,8}){1,3}", fullmatch=True),
                          st.from_regex(r"[a-z][a-z0-9_]{0,8}", fullmatch=True)), max_size=5))
def test_an_ask_reads_back_as_it_was_written(since: float, inputs: list[tuple[str, str]]) -> None:
    """What a node reads of an ask is what the executor wrote: the time to a microsecond, every
    (node, input) pair in order; anything else reads as an ask of no one."""
    got_since, got = parse_ask(ask_text(since, inputs))
    assert got == inputs and abs(got_since - since) <= 2e-6
    assert parse_ask("") == (0.0, []) and parse_ask("soon /listener:in") == (0.0, [])
