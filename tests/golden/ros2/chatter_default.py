#!/usr/bin/env python3
"""Reconfiguration plan for the ROS 2 system chatter: 5 steps, strategy default.

Architecture fingerprint: sha256:a187d17777a06185d1cb4ed3e17472de4874ed061b1d701e56a0ecbd77757072

    python3 this_file.py --dry-run     replay the plan against the embedded model (no ROS needed)
    python3 this_file.py               apply the plan to the running system (ROS 2 sourced)

Options: --yes (no confirmation prompt), --from-step N (resume at step N), --timeout S (per
service call), --step-timeout S (per step), --namespace NS (of the components' nodes).
Exit status: 0 every step done (or, with --dry-run, every state safe); 1 a state is unsafe
or a step failed; 2 bad usage or ROS 2 not available.

Each component runs one lifecycle node named after it that implements the reconf control
interface (docs/control-interface.md): parameters `reconf.mode.<functionality>` ("normal" or
"degraded") and `reconf.port.<port>` (the connectors the port is attached to), read and written
through the node's standard get_parameters / set_parameters services.

Generated from the plan below; edit the plan, not this file.
"""
from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import time
from fractions import Fraction

DOC = json.loads(r"""{
 "evidence": {
  "python_engine": "all 6 states valid"
 },
 "fingerprint": "sha256:a187d17777a06185d1cb4ed3e17472de4874ed061b1d701e56a0ecbd77757072",
 "format_version": 1,
 "model": {
  "components": [
   {
    "deployed": true,
    "functionalities": [
     {"criticality": 1, "degraded": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": null, "message": null, "text": "nothing"}}]}, "name": "talk", "normal": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": "10", "message": "String", "text": "String @ 10 Hz"}}]}, "ports": ["out"]}
    ],
    "host": "robot",
    "name": "talker",
    "ports": [
     {"assumption": null, "kind": "output", "message": "String", "name": "out"}
    ],
    "replaces": null,
    "run": "ros2 run demo_nodes_py talker"
   },
   {
    "deployed": true,
    "functionalities": [
     {"criticality": 1, "degraded": {"assumptions": [], "guarantees": []}, "name": "listen", "normal": {"assumptions": [{"hz": "10", "message": "String", "text": "String @ 10 Hz"}], "guarantees": []}, "ports": ["in"]}
    ],
    "host": "robot",
    "name": "listener",
    "ports": [
     {"assumption": {"hz": "10", "message": "String", "text": "String @ 10 Hz"}, "kind": "input", "message": "String", "name": "in"}
    ],
    "replaces": null,
    "run": "ros2 run demo_nodes_py listener"
   },
   {
    "deployed": false,
    "functionalities": [
     {"criticality": 1, "degraded": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": null, "message": null, "text": "nothing"}}]}, "name": "talk", "normal": {"assumptions": [], "guarantees": [{"port": "out", "predicate": {"hz": "10", "message": "String", "text": "String @ 10 Hz"}}]}, "ports": ["out"]}
    ],
    "host": "robot",
    "name": "talker_v2",
    "ports": [
     {"assumption": null, "kind": "output", "message": "String", "name": "out"}
    ],
    "replaces": "talker",
    "run": "ros2 run demo_nodes_py talker --ros-args -p version:=2"
   }
  ],
  "connectors": [
   {
    "guarantee": {
     "hz": "10",
     "message": "String",
     "text": "String @ 10 Hz"
    },
    "kind": "topic",
    "name": "/chatter",
    "publishers": [
     ["talker", "out"]
    ],
    "single": false,
    "single_publisher": false,
    "subscribers": [
     ["listener", "in"]
    ]
   }
  ],
  "environment": [],
  "hosts": [],
  "messages": [
   {
    "name": "String",
    "ros_type": "std_msgs/msg/String"
   }
  ],
  "name": "chatter"
 },
 "plan": {
  "disruption": 1,
  "left_degraded": [],
  "notes": [],
  "renames": {},
  "states": [
   {"components": ["listener", "talker"], "degraded": [], "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"]]},
   {"components": ["listener", "talker", "talker_v2"], "degraded": [["talker_v2", "talk"]], "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"]]},
   {"components": ["listener", "talker", "talker_v2"], "degraded": [], "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"]]},
   {"components": ["listener", "talker", "talker_v2"], "degraded": [], "roles": [["/chatter", "listener", "in"], ["/chatter", "talker", "out"], ["/chatter", "talker_v2", "out"]]},
   {"components": ["listener", "talker", "talker_v2"], "degraded": [], "roles": [["/chatter", "listener", "in"], ["/chatter", "talker_v2", "out"]]},
   {"components": ["listener", "talker_v2"], "degraded": [], "roles": [["/chatter", "listener", "in"], ["/chatter", "talker_v2", "out"]]}
  ],
  "steps": [
   {"action": "create", "component": "talker_v2"},
   {"action": "upgrade", "component": "talker_v2", "functionality": "talk"},
   {"action": "attach", "component": "talker_v2", "connector": "/chatter", "port": "out"},
   {"action": "detach", "component": "talker", "connector": "/chatter", "port": "out"},
   {"action": "remove", "component": "talker"}
  ],
  "strategy": "default",
  "verification": "full"
 },
 "system": "chatter"
}""")


PLAN = DOC["plan"]
MODEL = DOC["model"]
# Planning names of changed components and connectors (`name@new`) -> names in the running system.
RENAMES = PLAN.get("renames", {})
SYMBOLS = {"create": "+", "remove": "-", "attach": "\u2192", "detach": "\u00d7",
           "degrade": "\u2193", "upgrade": "\u2191"}


# --- the model: satisfaction exactly as DESIGN.md section 3 states it ---------------------

class State:
    """A configuration: present components, degraded (component, functionality), roles
    (connector, component, port)."""

    def __init__(self, components, degraded, roles):
        self.components = frozenset(components)
        self.degraded = frozenset(tuple(d) for d in degraded)
        self.roles = frozenset(tuple(r) for r in roles)

    @staticmethod
    def from_doc(d):
        return State(d["components"], d["degraded"], d["roles"])

    def key(self):
        return (self.components, self.degraded, self.roles)

    def describe(self):
        comps = ", ".join(sorted(self.components)) or "-"
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(self.degraded)) or "-"
        roles = ", ".join(f"{c}.{p}@{n}" for n, c, p in sorted(self.roles)) or "-"
        return f"components: {comps}\n    degraded: {degraded}\n    attachments: {roles}"


def rate(p):
    return None if p is None or p.get("hz") is None else Fraction(p["hz"])


def satisfies(p, q):
    """p satisfies q iff both are data of the same type and (q has no rate, or p has a rate >= q's)."""
    if p is None or q is None or p["message"] is None or q["message"] is None or p["message"] != q["message"]:
        return False
    q_hz = rate(q)
    if q_hz is None:
        return True
    p_hz = rate(p)
    return p_hz is not None and p_hz >= q_hz


class Model:
    def __init__(self, model):
        self.comps = {c["name"]: c for c in model["components"]}
        self.conns = {c["name"]: c for c in model["connectors"]}
        self.env = [e["guarantee"] for e in model["environment"]]

    def port(self, comp, name):
        for p in self.comps[comp]["ports"]:
            if p["name"] == name:
                return p
        return None

    def mode(self, comp, f, state):
        return f["degraded"] if (comp, f["name"]) in state.degraded else f["normal"]

    @staticmethod
    def guarantee(mode, port):
        for g in mode["guarantees"]:
            if g["port"] == port:
                return g["predicate"]
        return None

    def failures(self, state):
        """Every assumption of a present functionality's current mode that does not hold."""
        present = [c for c in sorted(state.components) if c in self.comps]
        publishers, feeds = {}, {}
        for conn, comp, pname in sorted(state.roles):
            if comp not in present or conn not in self.conns:
                continue
            p = self.port(comp, pname)
            if p is None:
                continue
            if p["kind"] == "output":
                publishers.setdefault(conn, []).append((comp, pname))
            else:
                feeds.setdefault((comp, pname), []).append(conn)

        def output_satisfies(comp, pname, want):
            return any(pname in f["ports"] and satisfies(self.guarantee(self.mode(comp, f, state), pname), want)
                       for f in self.comps[comp]["functionalities"])

        conn_sat = {name: any(output_satisfies(c, p, conn["guarantee"]) for c, p in publishers.get(name, []))
                    for name, conn in self.conns.items()}

        def input_sat(comp, p):
            return any(conn_sat[cn] and satisfies(self.conns[cn]["guarantee"], p["assumption"])
                       for cn in feeds.get((comp, p["name"]), []))

        def holds(comp, f, a):
            for pname in f["ports"]:
                p = self.port(comp, pname)
                if p is not None and p["kind"] == "input" and input_sat(comp, p) and satisfies(p["assumption"], a):
                    return True
            return any(satisfies(e, a) for e in self.env)

        out = []
        for comp in present:
            for f in self.comps[comp]["functionalities"]:
                for a in self.mode(comp, f, state)["assumptions"]:
                    if not holds(comp, f, a):
                        out.append(f"{comp}.{f['name']} assumes {a['text']}, which does not hold")
        return out

    def refusal(self, state, step):
        """Why `step` cannot run in `state` at all (the structural part of its preconditions)."""
        kind, comp = step["action"], step["component"]
        if kind == "create":
            if comp not in self.comps:
                return f"no component {comp} is declared"
            return f"{comp} is already in the system" if comp in state.components else None
        if comp not in state.components:
            return f"{comp} is not in the system"
        if kind == "remove":
            attached = [f"{comp}.{p} is attached to {n}" for n, c, p in sorted(state.roles) if c == comp]
            return f"{comp} is not isolated: " + "; ".join(attached) if attached else None
        if kind in ("attach", "detach"):
            if step["connector"] not in self.conns or self.port(comp, step["port"]) is None:
                return f"{comp}.{step['port']} or {step['connector']} is not declared"
            role = (step["connector"], comp, step["port"])
            if kind == "attach" and role in state.roles:
                return f"{comp}.{step['port']} is already attached to {step['connector']}"
            if kind == "detach" and role not in state.roles:
                return f"{comp}.{step['port']} is not attached to {step['connector']}"
            return None
        names = [f["name"] for f in self.comps[comp]["functionalities"]]
        fid = (comp, step["functionality"])
        if step["functionality"] not in names:
            return f"{comp} has no functionality {step['functionality']}"
        if kind == "degrade" and fid in state.degraded:
            return f"{comp}.{step['functionality']} is already degraded"
        if kind == "upgrade" and fid not in state.degraded:
            return f"{comp}.{step['functionality']} is not degraded"
        return None

    def effect(self, state, step):
        kind, comp = step["action"], step["component"]
        if kind == "remove":
            return State(state.components - {comp}, [d for d in state.degraded if d[0] != comp], state.roles)
        if kind == "create":
            funcs = [(comp, f["name"]) for f in self.comps[comp]["functionalities"]]
            return State(state.components | {comp}, state.degraded | set(funcs), state.roles)
        if kind in ("attach", "detach"):
            role = (step["connector"], comp, step["port"])
            roles = state.roles | {role} if kind == "attach" else state.roles - {role}
            return State(state.components, state.degraded, roles)
        fid = (comp, step["functionality"])
        degraded = state.degraded | {fid} if kind == "degrade" else state.degraded - {fid}
        return State(state.components, degraded, state.roles)


def describe(step):
    kind, comp = step["action"], step["component"]
    if kind == "create":
        return f"create {comp} (all functionalities degraded)"
    if kind == "remove":
        return f"remove {comp}"
    if kind == "attach":
        return f"attach {comp}.{step['port']} to {step['connector']}"
    if kind == "detach":
        return f"detach {comp}.{step['port']} from {step['connector']}"
    return f"{kind} {comp}.{step['functionality']}"


def label(i, step):
    return f"{i:>3}. {SYMBOLS.get(step['action'], '?')} {describe(step)}"


def replay(model, out):
    """Replay the plan from its first state; print every state; True when all are safe."""
    steps, recorded = PLAN["steps"], PLAN.get("states", [])
    state = State.from_doc(recorded[0]) if recorded else State([], [], [])
    ok, refused = True, None
    rows = [("  0.   initial state", state)]
    for i, step in enumerate(steps, 1):
        why = model.refusal(state, step)
        if why:
            refused = (i, step, why)
            break
        state = model.effect(state, step)
        if i < len(recorded) and State.from_doc(recorded[i]).key() != state.key():
            print(f"dry run: after step {i} the embedded plan records a different state than the steps give",
                  file=out)
            ok = False
        rows.append((label(i, step), state))
    unsafe = []
    for i, (text, st) in enumerate(rows):
        bad = model.failures(st)
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(st.degraded) if c in st.components) or "-"
        print(f"{text:<60} [{'UNSAFE' if bad else 'safe'}]  degraded: {degraded}", file=out)
        for reason in bad:
            print(f"       {reason}", file=out)
        if bad:
            unsafe.append(i)
    if refused is not None:
        i, step, why = refused
        print(f"{label(i, step):<60} [REFUSED]  {why}", file=out)
        print(f"dry run: step {i} ({describe(step)}) cannot run: {why}", file=out)
        ok = False
    if unsafe:
        where = ", ".join(f"step {i} ({describe(steps[i - 1])})" if i else "the initial state" for i in unsafe)
        print(f"dry run: UNSAFE after {where}", file=out)
        ok = False
    if ok:
        print(f"dry run: all {len(rows)} states are safe", file=out)
    return ok


# --- the running system -------------------------------------------------------------------

class StepFailed(Exception):
    pass


class Runtime:
    """Lifecycle services and the reconf control interface (parameters) of each component's node."""

    def __init__(self, args):
        try:
            import rclpy
            from lifecycle_msgs.msg import State as LcState, Transition
            from lifecycle_msgs.srv import ChangeState, GetState
            from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
            from rcl_interfaces.srv import GetParameters, SetParameters
        except ImportError as e:
            print(f"ROS 2 is not available ({e}). Source your ROS 2 installation first, e.g. "
                  "`source /opt/ros/$ROS_DISTRO/setup.bash`, or use --dry-run.", file=sys.stderr)
            raise SystemExit(2)
        self.rclpy, self.LcState, self.Transition = rclpy, LcState, Transition
        self.ChangeState, self.GetState = ChangeState, GetState
        self.Parameter, self.ParameterType, self.ParameterValue = Parameter, ParameterType, ParameterValue
        self.GetParameters, self.SetParameters = GetParameters, SetParameters
        self.timeout, self.step_timeout = args.timeout, args.step_timeout
        ns = args.namespace.strip("/")
        self.namespace = f"/{ns}" if ns else ""
        self.deadline = 0.0
        self.processes = {}
        self.clients = {}
        rclpy.init()
        name = "".join(ch if ch.isalnum() else "_" for ch in DOC["system"])
        self.node = rclpy.create_node(f"reconf_plan_{name}")

    def close(self):
        self.node.destroy_node()
        try:
            self.rclpy.shutdown()
        except Exception:
            pass

    def fqn(self, comp):
        return f"{self.namespace}/{RENAMES.get(comp, comp)}"

    def left(self):
        remaining = self.deadline - time.monotonic()
        if remaining <= 0:
            raise StepFailed(f"the step took longer than --step-timeout {self.step_timeout} s")
        return remaining

    def client(self, srv_type, name):
        if name not in self.clients:
            self.clients[name] = self.node.create_client(srv_type, name)
        return self.clients[name]

    def call(self, srv_type, name, request):
        cli = self.client(srv_type, name)
        if not cli.wait_for_service(timeout_sec=min(self.timeout, self.left())):
            raise StepFailed(f"service {name} is not available")
        fut = cli.call_async(request)
        self.rclpy.spin_until_future_complete(self.node, fut, timeout_sec=min(self.timeout, self.left()))
        if not fut.done():
            fut.cancel()
            raise StepFailed(f"no answer from {name} within {self.timeout} s")
        if fut.exception() is not None:
            raise StepFailed(f"{name} failed: {fut.exception()}")
        return fut.result()

    # lifecycle
    def lifecycle_state(self, comp):
        res = self.call(self.GetState, f"{self.fqn(comp)}/get_state", self.GetState.Request())
        return res.current_state.id, res.current_state.label

    def transition(self, comp, transition_id, name):
        req = self.ChangeState.Request()
        req.transition.id = transition_id
        res = self.call(self.ChangeState, f"{self.fqn(comp)}/change_state", req)
        if not res.success:
            raise StepFailed(f"{comp} refused the lifecycle transition {name}")

    def expect_lifecycle(self, comp, wanted, when):
        sid, slabel = self.lifecycle_state(comp)
        if sid not in wanted:
            raise StepFailed(f"{when}, {comp} is in lifecycle state {slabel!r}")
        return sid

    # control interface
    def get(self, comp, names):
        req = self.GetParameters.Request()
        req.names = list(names)
        res = self.call(self.GetParameters, f"{self.fqn(comp)}/get_parameters", req)
        values = {}
        for n, v in zip(names, res.values):
            if v.type == self.ParameterType.PARAMETER_STRING:
                values[n] = v.string_value
            elif v.type == self.ParameterType.PARAMETER_STRING_ARRAY:
                values[n] = sorted(v.string_array_value)
            else:
                raise StepFailed(f"{comp} does not implement the control interface: parameter {n} "
                                 "is not declared as a string or string array")
        return values

    def set(self, comp, name, value):
        pv = self.ParameterValue()
        if isinstance(value, str):
            pv.type, pv.string_value = self.ParameterType.PARAMETER_STRING, value
        else:
            pv.type, pv.string_array_value = self.ParameterType.PARAMETER_STRING_ARRAY, sorted(value)
        req = self.SetParameters.Request()
        req.parameters = [self.Parameter(name=name, value=pv)]
        res = self.call(self.SetParameters, f"{self.fqn(comp)}/set_parameters", req)
        if not res.results or not res.results[0].successful:
            reason = res.results[0].reason if res.results else "no result"
            raise StepFailed(f"{comp} refused {name}={value!r}: {reason}")

    def mode(self, comp, func):
        name = f"reconf.mode.{func}"
        return self.get(comp, [name])[name]

    def attachments(self, comp, port):
        name = f"reconf.port.{port}"
        return self.get(comp, [name])[name]

    # the six actions: precondition on the node, action, effect on the node
    def perform(self, step):
        self.deadline = time.monotonic() + self.step_timeout
        getattr(self, "do_" + step["action"])(step)

    def do_create(self, step):
        comp = step["component"]
        ns = self.namespace or "/"
        if (RENAMES.get(comp, comp), ns) in self.node.get_node_names_and_namespaces():
            raise StepFailed(f"before the step, a node {self.fqn(comp)} is already running")
        run = MODEL_RUN.get(comp)
        if not run:
            raise StepFailed(f"{comp} has no run command in the architecture")
        proc = subprocess.Popen(shlex.split(run), start_new_session=True)
        self.processes[comp] = proc
        cli = self.client(self.GetState, f"{self.fqn(comp)}/get_state")
        while not cli.wait_for_service(timeout_sec=min(0.2, self.left())):
            if proc.poll() is not None:
                raise StepFailed(f"{run!r} exited with status {proc.returncode} before {comp} came up")
        sid = self.expect_lifecycle(comp, (self.LcState.PRIMARY_STATE_UNCONFIGURED, self.LcState.PRIMARY_STATE_INACTIVE),
                                    "after start")
        if sid == self.LcState.PRIMARY_STATE_UNCONFIGURED:
            self.transition(comp, self.Transition.TRANSITION_CONFIGURE, "configure")
        self.transition(comp, self.Transition.TRANSITION_ACTIVATE, "activate")
        self.expect_lifecycle(comp, (self.LcState.PRIMARY_STATE_ACTIVE,), "after activate")
        info = MODEL_COMPONENTS[comp]
        values = self.get(comp, [f"reconf.mode.{f}" for f in info["functionalities"]]
                          + [f"reconf.port.{p}" for p in info["ports"]])
        wrong = [f"{n}={v!r}" for n, v in values.items()
                 if (n.startswith("reconf.mode.") and v != "degraded") or (n.startswith("reconf.port.") and v)]
        if wrong:
            raise StepFailed(f"{comp} should start with every functionality degraded and no attachment, "
                             f"but has {', '.join(wrong)}")

    def do_remove(self, step):
        comp = step["component"]
        sid = self.expect_lifecycle(comp, (self.LcState.PRIMARY_STATE_ACTIVE, self.LcState.PRIMARY_STATE_INACTIVE),
                                    "before the step")
        ports = MODEL_COMPONENTS[comp]["ports"]
        attached = {n: v for n, v in self.get(comp, [f"reconf.port.{p}" for p in ports]).items() if v}
        if attached:
            raise StepFailed(f"before the step, {comp} is not isolated: "
                             + ", ".join(f"{n}={v!r}" for n, v in sorted(attached.items())))
        if sid == self.LcState.PRIMARY_STATE_ACTIVE:
            self.transition(comp, self.Transition.TRANSITION_DEACTIVATE, "deactivate")
        self.transition(comp, self.Transition.TRANSITION_CLEANUP, "cleanup")
        self.transition(comp, self.Transition.TRANSITION_UNCONFIGURED_SHUTDOWN, "shutdown")
        self.expect_lifecycle(comp, (self.LcState.PRIMARY_STATE_FINALIZED,), "after shutdown")
        proc = self.processes.pop(comp, None)
        if proc is not None and proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=max(0.1, min(self.timeout, self.deadline - time.monotonic())))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    def do_attach(self, step):
        self.port_step(step, attach=True)

    def do_detach(self, step):
        self.port_step(step, attach=False)

    def port_step(self, step, attach):
        comp, port, conn = step["component"], step["port"], RENAMES.get(step["connector"], step["connector"])
        self.expect_lifecycle(comp, (self.LcState.PRIMARY_STATE_ACTIVE,), "before the step")
        now = self.attachments(comp, port)
        if (conn in now) == attach:
            raise StepFailed(f"before the step, {comp}.{port} is {'already' if attach else 'not'} attached to {conn} "
                             f"(reconf.port.{port}={now!r})")
        self.set(comp, f"reconf.port.{port}", sorted(set(now) | {conn}) if attach else [c for c in now if c != conn])
        after = self.attachments(comp, port)
        if (conn in after) != attach:
            raise StepFailed(f"after the step, reconf.port.{port} of {comp} is {after!r}")

    def do_degrade(self, step):
        self.mode_step(step, "normal", "degraded")

    def do_upgrade(self, step):
        self.mode_step(step, "degraded", "normal")

    def mode_step(self, step, before, after):
        comp, func = step["component"], step["functionality"]
        self.expect_lifecycle(comp, (self.LcState.PRIMARY_STATE_ACTIVE,), "before the step")
        now = self.mode(comp, func)
        if now != before:
            raise StepFailed(f"before the step, {comp}.{func} is {now!r}, not {before!r}")
        self.set(comp, f"reconf.mode.{func}", after)
        now = self.mode(comp, func)
        if now != after:
            raise StepFailed(f"after the step, {comp}.{func} is {now!r}, not {after!r}")


MODEL_RUN = {c["name"]: c["run"] for c in MODEL["components"]}
MODEL_COMPONENTS = {c["name"]: {"functionalities": [f["name"] for f in c["functionalities"]],
                                "ports": [p["name"] for p in c["ports"]]} for c in MODEL["components"]}


def apply_plan(args, first):
    steps, recorded = PLAN["steps"], PLAN.get("states", [])
    print(f"applying steps {first}..{len(steps)} of the plan for {DOC['system']} ({DOC['fingerprint']})")
    for i in range(first, len(steps) + 1):
        print(label(i, steps[i - 1]))
    rt = Runtime(args)
    try:
        if not args.yes:
            try:
                answer = input("Apply these steps to the running system? [y/N] ")
            except EOFError:
                answer = ""
            if answer.strip().lower() not in ("y", "yes"):
                print("nothing done")
                return 1
        for i in range(first, len(steps) + 1):
            step = steps[i - 1]
            print(f"{label(i, step)} ...", flush=True)
            try:
                rt.perform(step)
            except (StepFailed, OSError, KeyboardInterrupt) as e:
                why = "interrupted" if isinstance(e, KeyboardInterrupt) else str(e)
                print(f"step {i} ({describe(step)}) FAILED: {why}", file=sys.stderr)
                last = State.from_doc(recorded[i - 1]).describe() if i - 1 < len(recorded) else "unknown"
                print(f"The system is left in the state before step {i} (the last good state of the plan), "
                      f"unless step {i} was partly done:\n    {last}\n"
                      f"Fix the cause, then resume with --from-step {i}.", file=sys.stderr)
                return 1
            print("      done")
    finally:
        rt.close()
    print(f"all {len(steps) - first + 1} steps done")
    return 0


def main(argv=None):
    try:
        sys.stdout.reconfigure(errors="replace")
    except AttributeError:
        pass
    ap = argparse.ArgumentParser(description=f"Reconfiguration plan for {DOC['system']} ({DOC['fingerprint']}).")
    ap.add_argument("--dry-run", action="store_true", help="replay the plan against the embedded model; no ROS")
    ap.add_argument("--yes", "-y", action="store_true", help="do not ask for confirmation")
    ap.add_argument("--from-step", type=int, default=1, metavar="N", help="resume at step N (1-based)")
    ap.add_argument("--timeout", type=float, default=5.0, metavar="S", help="per service call, in seconds")
    ap.add_argument("--step-timeout", type=float, default=30.0, metavar="S", help="per step, in seconds")
    ap.add_argument("--namespace", default="", help="namespace of the components' nodes")
    args = ap.parse_args(argv)
    steps = PLAN["steps"]
    if not 1 <= args.from_step <= max(1, len(steps)):
        ap.error(f"--from-step must be between 1 and {max(1, len(steps))}")
    if args.timeout <= 0 or args.step_timeout <= 0:
        ap.error("timeouts must be positive")
    print(f"plan for {DOC['system']} ({DOC['fingerprint']}): {len(steps)} steps, strategy {PLAN.get('strategy')}, "
          f"disruption {PLAN.get('disruption')}")
    for key, value in sorted(DOC.get("evidence", {}).items()):
        print(f"evidence: {key}: {json.dumps(value, sort_keys=True)}")
    safe = replay(Model(MODEL), sys.stdout)
    if args.dry_run or not safe:
        if not safe and not args.dry_run:
            print("refusing to apply an unsafe plan", file=sys.stderr)
        return 0 if safe else 1
    if not steps:
        print("nothing to do")
        return 0
    return apply_plan(args, args.from_step)


if __name__ == "__main__":
    sys.exit(main())
