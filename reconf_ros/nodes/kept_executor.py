"""A single-threaded rclpy executor that keeps its wait set's entities between wake-ups
(docs/runtime.md#cost).

rclpy's executor, at every wake-up, gathers every entity of every node it spins, enters each
one's handle, sizes a new wait set and adds them to it, all in Python, and after the wait walks
them all again to find the ready ones; each callback it runs then triggers its guard condition
twice, so the next wait returns at once for nothing. In a process of ten FTM nodes under a stream
of requests that was four fifths of the CPU. `KeptExecutor` gathers and enters the entities only
when they change (a node creates or destroys one, or a node is added or removed: rclpy wakes the
executor for each, `wake`), adds the kept handles to one kept wait set, and finds the ready ones
by their handles' pointers.

Contract: as `rclpy.executors.SingleThreadedExecutor`'s, for the thread that spins it.
- `spin_once(timeout_sec)` waits for work up to `timeout_sec` and runs one ready callback: a
  timer's, a subscription's (with its message info when the callback takes it), a service's (its
  response sent), a client's (its future's result set), a guard condition's or a waitable's, each
  taken through rclpy's own `_take_*` so that what a callback receives is rclpy's.
- Callbacks run one at a time, in the thread that spins. While a task is outstanding (a future's
  done callback, `create_task`, a coroutine callback that awaits), a wake-up is rclpy's own, so
  callback groups hold exactly as they do in rclpy; a callback that suspends becomes such a task.
- `shutdown()` lets go of the kept handles before rclpy's shutdown: call it before destroying the
  nodes (`run_components` does), or their destruction waits for the executor's last use.
- `wait_for_ready_callbacks(nodes=[...])` (a subset of the nodes) is rclpy's own.
"""
from __future__ import annotations

from contextlib import ExitStack
from typing import Any, Callable, Generator, Optional, Union

from rclpy.exceptions import InvalidHandle
from rclpy.executors import (
    ExternalShutdownException,
    ShutdownException,
    SingleThreadedExecutor,
    TimeoutException,
    TimeoutObject,
)
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.task import Task
from rclpy.timer import Timer
from rclpy.utilities import timeout_sec_to_nsec
from rclpy.waitable import NumberOfEntities

__all__ = ["KeptExecutor"]

KINDS = ("subscription", "timer", "client", "service", "guard_condition")


class _Kept:
    """The entities of every node, their handles entered, and one wait set sized for them."""

    def __init__(self, executor: "KeptExecutor", nodes: list[Any]) -> None:
        self.stack = ExitStack()
        self.by_pointer: dict[str, dict[int, tuple[Any, Any]]] = {k: {} for k in KINDS}
        self.handles: dict[str, list[Any]] = {k: [] for k in KINDS}
        self.waitables: list[tuple[Any, Any]] = []
        self.node_guards: list[Any] = []
        inside = NumberOfEntities()      # what the waitables add to the wait set
        for node in nodes:
            for kind, entities in (("subscription", node.subscriptions), ("timer", node.timers),
                                   ("client", node.clients), ("service", node.services),
                                   ("guard_condition", node.guards)):
                for e in entities:
                    self._enter(kind, e.handle, e, node)
                    if kind == "guard_condition":
                        self.node_guards.append(e)
            for w in node.waitables:
                try:
                    self.stack.enter_context(w)
                except InvalidHandle:
                    continue
                inside += w.get_num_entities()
                self.waitables.append((w, node))
        own = [g for g in (executor._guard, executor._sigint_gc) if g]
        for g in own:
            self._enter("guard_condition", g.handle, None, None)
        context = executor._context.handle
        if context is None:
            raise RuntimeError("the executor's context is shut down")
        self.stack.enter_context(context)
        n = {k: len(v) for k, v in self.handles.items()}
        self.wait_set = _rclpy.WaitSet(n["subscription"] + inside.num_subscriptions,
                                       n["guard_condition"] + inside.num_guard_conditions,
                                       n["timer"] + inside.num_timers + 1,          # + the timeout's
                                       n["client"] + inside.num_clients, n["service"] + inside.num_services,
                                       inside.num_events, context)

    def _enter(self, kind: str, handle: Any, entity: Any, node: Any) -> None:
        try:
            self.stack.enter_context(handle)
        except InvalidHandle:
            return
        self.handles[kind].append(handle)
        if entity is not None:
            self.by_pointer[kind][handle.pointer] = (entity, node)

    def fill(self, timeout_timer: Optional[Timer]) -> Any:
        ws = self.wait_set
        ws.clear_entities()
        for h in self.handles["subscription"]:
            ws.add_subscription(h)
        for h in self.handles["client"]:
            ws.add_client(h)
        for h in self.handles["service"]:
            ws.add_service(h)
        for h in self.handles["timer"]:
            ws.add_timer(h)
        if timeout_timer is not None:
            ws.add_timer(timeout_timer.handle)
        for h in self.handles["guard_condition"]:
            ws.add_guard_condition(h)
        for w, _ in self.waitables:
            w.add_to_wait_set(ws)
        return ws


class KeptExecutor(SingleThreadedExecutor):
    """SingleThreadedExecutor with the wait set's entities kept between wake-ups (module doc)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._kept: Optional[_Kept] = None
        self._stale = True

    # --- what changes the entities ---
    def wake(self) -> None:
        self._stale = True
        super().wake()

    def add_node(self, node: Any) -> bool:
        self._stale = True
        return super().add_node(node)

    def remove_node(self, node: Any) -> None:
        self._stale = True
        super().remove_node(node)

    def shutdown(self, timeout_sec: Optional[float] = None) -> bool:
        self._release()
        return super().shutdown(timeout_sec)

    def _release(self) -> None:
        if self._kept is not None:
            self._kept.stack.close()
            self._kept = None
        self._stale = True

    # --- the wait ---
    def _outstanding(self) -> bool:
        with self._tasks_lock:
            self._tasks = [t for t in self._tasks if not t[0].done() and not t[0].cancelled()]
            return bool(self._tasks)

    def _wait_for_ready_callbacks(self, timeout_sec: Optional[Union[float, TimeoutObject]] = None,
                                  nodes: Optional[list[Any]] = None,
                                  condition: Callable[[], bool] = lambda: False
                                  ) -> Generator[tuple[Task[None], Any, Any], None, None]:
        if nodes is not None or self._outstanding():
            yield from super()._wait_for_ready_callbacks(timeout_sec, nodes, condition)
            return
        timeout_nsec = timeout_sec_to_nsec(timeout_sec.timeout if isinstance(timeout_sec, TimeoutObject)
                                           else timeout_sec)
        timeout_timer = (Timer(None, None, timeout_nsec, self._clock, context=self._context)
                         if timeout_nsec > 0 else None)
        yielded = False
        while not yielded and not self._is_shutdown and not condition():
            if self._stale or self._kept is None:
                self._release()
                self._stale = False
                self._kept = _Kept(self, self.get_nodes())
            kept = self._kept
            for gc in kept.node_guards:         # triggered but not handled: wait on it again
                if gc._executor_triggered:
                    gc.trigger()
            ws = kept.fill(timeout_timer)
            ws.wait(timeout_nsec)
            if self._is_shutdown:
                raise ShutdownException()
            if not self._context.ok():
                raise ExternalShutdownException()
            ready = {k: ws.get_ready_entities(k) for k in KINDS}
            for gc_ptr in ready["guard_condition"]:
                entry = kept.by_pointer["guard_condition"].get(gc_ptr)
                if entry is not None:
                    entry[0]._executor_triggered = True
            work: list[tuple[Callable[[Any], Any], Any, Any]] = [
                (self._take_waitable, w, node) for w, node in kept.waitables if w.is_ready(ws)]
            work += [(take, *kept.by_pointer[kind][p]) for kind, take in self._takers()
                     for p in ready[kind] if p in kept.by_pointer[kind]]
            work += [(self._take_guard_condition, gc, None) for gc in kept.node_guards if gc._executor_triggered]
            for take, entity, node in work:
                task = self._task(take, entity)
                if task is None:
                    continue
                yielded = True
                yield task, entity, node
                if not task.done():             # it awaits: it goes on as rclpy's tasks do
                    with self._tasks_lock:
                        self._tasks.append((task, entity, node))
                    return
                if self._stale:     # it made or destroyed an entity: what is still ready, the next wait says
                    return
            if timeout_nsec == 0 or (timeout_timer is not None
                                     and timeout_timer.handle.pointer in ready["timer"]):
                raise TimeoutException()

    def _takers(self) -> tuple[tuple[str, Callable[[Any], Any]], ...]:
        return (("timer", self._take_ready_timer), ("subscription", self._take_subscription),
                ("client", self._take_client), ("service", self._take_service))

    def _take_ready_timer(self, tmr: Any) -> Any:
        # rclpy's check: a cancelled timer can be reported ready
        return self._take_timer(tmr) if tmr.handle.is_timer_ready() else None

    def _task(self, take: Callable[[Any], Any], entity: Any) -> Optional[Task[None]]:
        try:
            execute = take(entity)
        except InvalidHandle:
            return None
        return None if execute is None else Task(execute, executor=self)
