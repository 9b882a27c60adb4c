"""The node an adapter drives (docs/adapter.md): its process, started from the component's run
line with its node and ports renamed to private names (`--ros-args -r`), and a hidden node of
the adapter's process that talks to it: its lifecycle and parameter services, and its private
topics (the node's outputs read, its inputs written, serialized, never deserialized).

The hidden node spins in a thread of its own, so that the adapter's node can wait for the
wrapped node's answer inside its own callbacks (a control-interface change is made before
the answer, docs/control-interface.md). Nothing of the wrapped node's code is imported: it can
be written in any language.
"""
from __future__ import annotations

import ctypes
import functools
import os
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from typing import Any, Callable, Optional

from reconf_dsl.ir import ParamValue, RosNode

__all__ = ["Wrapped", "WrappedFailed", "PRIVATE_PREFIX", "ros_namespace"]

PRIVATE_PREFIX = "_wrapped_"   # the wrapped node's name: hidden (a leading underscore), never a component
UP_TIMEOUT = 20.0              # s for the wrapped node to appear (the executor's step allows 30)
CALL_TIMEOUT = 4.0             # s for one of its services to answer (the executor waits 5 for ours)
STOP_GRACE = 2.0               # s between SIGTERM and SIGKILL
PUBLISHER_WAIT = 1.0           # s to wait for an output's publisher, to take its QoS
PRIVATE_DEPTH = 100


class WrappedFailed(Exception):
    """The wrapped node could not be started, or did not answer; the message says why."""


def ros_namespace(ros_args: list[str]) -> str:
    """The namespace `--ros-args -r __ns:=/NS` gives the process ("" for the root)."""
    for i, arg in enumerate(ros_args[:-1]):
        if arg in ("-r", "--remap") and ros_args[i + 1].startswith("__ns:="):
            return "/" + ros_args[i + 1].split(":=", 1)[1].strip("/")
    return ""


def _die_with_parent() -> None:
    """In the child, before exec: SIGTERM when the adapter dies, however it dies (PR_SET_PDEATHSIG)."""
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


class Wrapped:
    """One wrapped node: its process, its private names, and the hidden node that drives it."""

    def __init__(self, run: str, node: RosNode, name: str, namespace: str) -> None:
        self.run, self.spec, self.namespace = run, node, namespace.rstrip("/")
        self.private = PRIVATE_PREFIX + name.lstrip("_")
        self.fqn = f"{self.namespace}/{self.private}"
        self.proc: Optional[subprocess.Popen[bytes]] = None
        self.stopping = False
        self.lifecycle = "unknown" if node.lifecycle else "plain"
        self.driver: Any = None
        self.executor: Any = None
        self.thread: Optional[threading.Thread] = None
        self.clients: dict[str, Any] = {}
        self.readers: dict[str, Any] = {}      # output port -> its private subscription
        self.reader_qos: dict[str, Any] = {}
        self.writers: dict[str, Any] = {}      # input port -> its private publisher

    # --- the process ---
    def topic(self, port: str) -> str:
        """The private name of `port`'s topic."""
        return f"{self.fqn}/{port}"

    def command(self) -> list[str]:
        """The run line with the node renamed, put in the namespace, and each port's topic remapped
        to its private name. A rule prefixed with a node's name applies to that node only; rcl
        matches the rules after the first against the node's new name, and a topic's name as the
        node resolves it in its namespace."""
        argv = shlex.split(self.run)
        exe = shutil.which(argv[0]) or shutil.which(argv[0], path=os.path.dirname(sys.executable))
        if exe is None:
            raise WrappedFailed(f"{argv[0]!r}, the run command of node {self.spec.name}, is not found")
        argv[0] = exe
        n = self.spec.name
        p = self.private
        rules = [f"{n}:__node:={p}"] + ([f"{p}:__ns:={self.namespace}"] if self.namespace else [])
        rules += [f"{p}:{t.ros_name}:={self.topic(t.port)}" for t in self.spec.topics]
        at = argv.index("--ros-args") + 1 if "--ros-args" in argv else len(argv)
        extra = ([] if "--ros-args" in argv else ["--ros-args"]) + [x for r in rules for x in ("-r", r)]
        return argv[:at] + extra + argv[at:]

    def start(self) -> None:
        """Start the process (before rclpy.init: a process with DDS threads must not fork), in the
        adapter's process group, its output into the adapter's."""
        argv = self.command()
        print(f"reconf adapter: starting node {self.spec.name} as {self.fqn}: {shlex.join(argv)}", flush=True)
        self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, preexec_fn=_die_with_parent)

    def poll(self) -> Optional[int]:
        """The process's exit status once it has exited, else None."""
        return None if self.proc is None else self.proc.poll()

    def stop(self) -> Optional[int]:
        """End the process: SIGTERM, then SIGKILL after STOP_GRACE s. Its exit status."""
        self.stopping = True
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=STOP_GRACE)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode

    # --- the hidden node ---
    def connect(self) -> None:
        """Make the hidden node, its service clients and its own executor thread (after rclpy.init)."""
        import rclpy
        from lifecycle_msgs.srv import ChangeState, GetState
        from rcl_interfaces.srv import SetParameters
        from rclpy.executors import SingleThreadedExecutor

        from ..executor.status import tool_node
        self.driver = rclpy.create_node(tool_node(f"adapter_{self.private}"), namespace=self.namespace or None)
        self.clients = {"get_state": self.driver.create_client(GetState, f"{self.fqn}/get_state"),
                        "change_state": self.driver.create_client(ChangeState, f"{self.fqn}/change_state"),
                        "set_parameters": self.driver.create_client(SetParameters, f"{self.fqn}/set_parameters")}
        # not rclpy's EventsExecutor: in 9.1.2, while it spins in one thread, create_task and the
        # node's graph queries from another wait forever (docs/adapter.md#what-it-costs)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.driver)
        self.thread = threading.Thread(target=self._spin, name=f"driver {self.private}", daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:       # the context was shut down under it: the process is ending
            pass

    def wait_up(self, timeout: float = UP_TIMEOUT) -> None:
        """Until the wrapped node is in the graph (and serves its lifecycle, if it has one)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            code = self.poll()
            if code is not None:
                raise WrappedFailed(f"node {self.spec.name}'s process ({shlex.join(self.command())}) exited with "
                                    f"status {code} before its node came up")
            if self.fqn in self._graph() and (not self.spec.lifecycle or self.clients["get_state"].service_is_ready()):
                return
            time.sleep(0.05)
        others = sorted(n for n in self._graph() if not n.rsplit("/", 1)[1].startswith("_"))
        raise WrappedFailed(f"no node {self.fqn} appeared within {timeout:g} s: is {self.spec.name} the name of the "
                            f"node in its executable (its `node` block)? Nodes seen: {', '.join(others) or 'none'}")

    def _graph(self) -> set[str]:
        return {f"{ns.rstrip('/')}/{n}" for n, ns in self.driver.get_node_names_and_namespaces()}

    def close(self) -> None:
        """Stop the process, then the hidden node's thread (again: nothing more)."""
        self.stop()
        if self.executor is not None and self.thread is not None:
            self.executor.shutdown(timeout_sec=1.0)
        if self.thread is not None:
            self.thread.join(timeout=2.0)
        if self.driver is not None:
            try:
                self.driver.destroy_node()
            except Exception:
                pass
        self.executor = self.thread = self.driver = None

    # --- its services, called from another thread and waited for ---
    def _call(self, service: str, request: Any, what: str) -> Any:
        client = self.clients[service]
        if not client.wait_for_service(timeout_sec=CALL_TIMEOUT):
            raise WrappedFailed(f"{self.fqn}/{service} is not available ({what})")
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(CALL_TIMEOUT) and not future.done():
            client.remove_pending_request(future)
            raise WrappedFailed(f"{self.fqn} did not answer {what} within {CALL_TIMEOUT:g} s")
        return future.result()

    def state(self) -> str:
        """The wrapped lifecycle node's state, by label, as it answers now."""
        from lifecycle_msgs.srv import GetState
        self.lifecycle = str(self._call("get_state", GetState.Request(), "get_state").current_state.label)
        return self.lifecycle

    def transition(self, label: str) -> None:
        """Take the wrapped lifecycle node through transition `label` (`configure`, `activate`, ...)."""
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState
        ids = {"configure": Transition.TRANSITION_CONFIGURE, "activate": Transition.TRANSITION_ACTIVATE,
               "deactivate": Transition.TRANSITION_DEACTIVATE, "cleanup": Transition.TRANSITION_CLEANUP,
               "shutdown": {"unconfigured": Transition.TRANSITION_UNCONFIGURED_SHUTDOWN,
                            "inactive": Transition.TRANSITION_INACTIVE_SHUTDOWN,
                            "active": Transition.TRANSITION_ACTIVE_SHUTDOWN}.get(self.lifecycle, 0)}
        req = ChangeState.Request()
        req.transition.id = ids[label]
        if not self._call("change_state", req, label).success:
            self.state()
            raise WrappedFailed(f"{self.fqn} refused the lifecycle transition {label} (it is {self.lifecycle})")
        self.state()

    def set_parameters(self, values: list[tuple[str, ParamValue]]) -> None:
        """Set the wrapped node's parameters, in order; the first refusal is raised."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter
        if not values:
            return
        req = SetParameters.Request()
        req.parameters = [Parameter(name, value=value).to_parameter_msg() for name, value in values]
        results = self._call("set_parameters", req, "set_parameters").results
        for (name, value), r in zip(values, results):
            if not r.successful:
                raise WrappedFailed(f"{self.fqn} refused {name} = {value!r}: {r.reason or 'no reason given'}")

    # --- its topics, private: made in the hidden node's thread ---
    def in_driver(self, work: Callable[[], Any]) -> Any:
        """Run `work` in the hidden node's thread (its entities are made and destroyed there)."""
        if self.executor is None:
            return work()
        task = self.executor.create_task(work)
        done = threading.Event()
        task.add_done_callback(lambda _: done.set())
        self.executor.wake()
        if not done.wait(CALL_TIMEOUT) and not task.done():
            raise WrappedFailed(f"the adapter's own thread did not run in {CALL_TIMEOUT:g} s")
        return task.result()

    def read_outputs(self, ports: dict[str, Any], relay: Callable[[str, bytes], None]) -> None:
        """Subscribe to each output port's private topic (port -> message class), with the QoS
        its publishers offer, and hand every message to `relay(port, data)` as it came."""
        end = time.monotonic() + PUBLISHER_WAIT
        while time.monotonic() < end and not all(self.driver.count_publishers(self.topic(p)) for p in ports):
            time.sleep(0.02)
        for port, cls in ports.items():
            self.in_driver(functools.partial(self._reader, port, cls, relay))

    def _reader(self, port: str, cls: Any, relay: Callable[[str, bytes], None]) -> None:
        qos = self._offered(self.topic(port))
        if port in self.readers:
            if self.reader_qos.get(port) == (qos.reliability, qos.durability):
                return
            self.driver.destroy_subscription(self.readers.pop(port))
        self.reader_qos[port] = (qos.reliability, qos.durability)
        self.readers[port] = self.driver.create_subscription(cls, self.topic(port), functools.partial(relay, port),
                                                             qos, raw=True)

    def _offered(self, topic: str) -> Any:
        """What a reader of `topic` asks so that every publisher there matches: reliable if they all
        are, transient local if they all keep their data (a latched map, say), else volatile."""
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        pubs = [e.qos_profile for e in self.driver.get_publishers_info_by_topic(topic)]
        reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in pubs)
        durable = bool(pubs) and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in pubs)
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=PRIVATE_DEPTH,
                          reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL if durable else DurabilityPolicy.VOLATILE)

    def recheck_outputs(self, ports: dict[str, Any], relay: Callable[[str, bytes], None]) -> None:
        """Take the QoS of publishers that came (or changed) since: a reader that hears nobody while
        the node publishes is made again with what they offer. In the hidden node's thread."""
        for port, cls in ports.items():
            reader = self.readers.get(port)
            if reader is None or (reader.get_publisher_count() == 0 and self.driver.count_publishers(self.topic(port))):
                self._reader(port, cls, relay)

    def write_inputs(self, ports: dict[str, Any]) -> None:
        """A private publisher for each input port (port -> message class), offering the most (reliable,
        transient local) so that whatever the node's subscription asks, it matches."""
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=PRIVATE_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)

        def make() -> None:
            for port, cls in ports.items():
                if port not in self.writers:
                    self.writers[port] = self.driver.create_publisher(cls, self.topic(port), qos)
        self.in_driver(make)

    def write(self, port: str, data: bytes) -> None:
        self.writers[port].publish(data)
