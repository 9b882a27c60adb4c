"""Run Alloy modules through the Alloy 6 jar in-process (JPype).

Every module is passed in memory under /alloyvfs/ (this Alloy build mis-resolves `open`
when a directory on the path contains a dot), so `modules` maps names such as
"main.als" and "reconf/x.als" to their text and `open reconf/x` finds the latter.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, NamedTuple, Protocol

from checker.alloy.errors import AlloyError, AlloyUnavailable
from checker.alloy.jvm import ensure_jvm, java_class
from checker.alloy.split import Split, skeleton_key, split_module

VFS = "/alloyvfs/"
# parsed skeletons kept for the next modules (a plan's windows share one, a check's slices another)
SKELETONS = 8


class Solver(NamedTuple):
    """A SAT solver reconf offers: the name `--solver` takes, the analyzer's id for it
    (A4Options.SatSolver), and the Kodkod SATFactory constant of a native one (None: pure Java)."""

    name: str
    analyzer: str
    native: str | None


# The one table of solvers: every command's `--solver` choices, the README's list (a test holds
# it to this) and the fallback come from here; the first is the default. Each native solver's
# library ships in the Alloy jar and is probed before use; one that does not load falls back to
# the pure-Java one. Not offered: plingeling (an external program the jar has for macOS only)
# and cryptominisat (the analyzer fails on it with a NullPointerException on Linux x86-64).
SOLVER_TABLE = (
    Solver("glucose41", "glucose 4.1(jni)", "Glucose41"),
    Solver("glucose", "glucose(jni)", "Glucose"),
    Solver("lingeling", "lingeling(jni)", "Lingeling"),
    Solver("minisat", "minisat(jni)", "MiniSat"),
    Solver("minisatprover", "minisatprover(jni)", "MiniSatProver"),
    Solver("sat4j", "sat4j", None),
)
SOLVER_NAMES = tuple(s.name for s in SOLVER_TABLE)
DEFAULT_SOLVER = SOLVER_TABLE[0].name
FALLBACK_SOLVER = next(s.analyzer for s in SOLVER_TABLE if s.native is None)

# name -> A4Options.SatSolver id; the jar's own ids work too (through the Python API)
SOLVER_ALIASES = {s.name: s.analyzer for s in SOLVER_TABLE}

Tuples = set[tuple[str, ...]]

# A4Options.SatSolver id -> the kodkod SATFactory constant behind it (probed cheaply)
_SAT_FACTORIES = {s.analyzer: s.native for s in SOLVER_TABLE if s.native is not None}


@dataclass
class CommandOutcome:
    """The result of one Alloy command.

    For a check, `satisfiable` means a counterexample was found; for a run, an instance.
    `as_expected` compares with the command's `expect` (None when it has none).
    """

    label: str
    is_check: bool
    expects: int | None
    satisfiable: bool
    elapsed: float
    solver: str
    scope: str = ""
    evaluated: dict[str, Tuples] = field(default_factory=dict)
    _evaluator: Callable[[str], Tuples] | None = field(default=None, repr=False, compare=False)

    @property
    def outcome(self) -> str:
        if self.is_check:
            return "counterexample" if self.satisfiable else "no counterexample"
        return "instance" if self.satisfiable else "no instance"

    @property
    def as_expected(self) -> bool | None:
        if self.expects is None or self.expects < 0:
            return None
        return (1 if self.satisfiable else 0) == self.expects

    def eval(self, expr: str) -> Tuples:
        """The value of an Alloy expression in the instance/counterexample, as tuples of
        atom names (e.g. {("Component$0",)})."""
        if expr in self.evaluated:
            return self.evaluated[expr]
        if self._evaluator is None:
            raise AlloyError(f"no solution to evaluate {expr!r} in ({self.outcome})")
        value = self._evaluator(expr)
        self.evaluated[expr] = value
        return value


@dataclass
class Trace:
    """A solved module's instance, state by state: whether there is one, the seconds the
    solver took, and per state the value of each expression asked for, as tuples of atom
    labels (`atom_name` gives the sig's name); a static instance has one state."""

    satisfiable: bool
    seconds: float
    states: list[dict[str, Tuples]] = field(default_factory=list)


@dataclass
class _World:
    """A parsed main module and the atoms declared for it through the API. A world built
    on a reused skeleton (`_Skeleton`) is current until the skeleton serves another."""

    module: Any
    extra_sigs: list[Any]
    skeleton: "_Skeleton | None" = None
    generation: int = 0

    def sigs(self) -> Any:
        from java.util import ArrayList  # type: ignore[import-not-found]

        if not self.extra_sigs:
            return self.module.getAllReachableSigs()
        every = ArrayList()
        for sig in list(self.module.getAllReachableSigs()) + self.extra_sigs:
            every.add(sig)
        return every

    @property
    def current(self) -> bool:
        return self.skeleton is None or self.skeleton.generation == self.generation


class _Skeleton:
    """A parsed skeleton (`checker.alloy.split`), kept to serve the next module with the
    same one: the windows of a plan, the slices of a configuration. Its atoms, declared
    through the API, are added as children of its sigs and bound as globals; `reset`
    takes them away again (the analyzer has no API for that: its private lists are reached
    by reflection), so each module sees exactly its own atoms."""

    def __init__(self, module: Any) -> None:
        self.module = module
        self.generation = 0
        reachable = list(module.getAllReachableSigs())
        # by name, for the atoms' parents and the bodies to set
        self.sigs = {str(s.label).removeprefix("this/"): s for s in reachable}
        self.funcs = {str(f.label).removeprefix("this/"): f for f in module.getAllFunc()}
        children, items, globals_ = self._fields()
        lists = [items.get(children.get(s)) for s in reachable if children.getDeclaringClass().isInstance(s)]
        # each sig's own children, and the globals (none: the skeleton declares no atom by API)
        self.children = [(kids, int(kids.size())) for kids in lists]
        self.globals = globals_.get(module)
        self.usable = int(self.globals.size()) == 0

    @staticmethod
    def _fields() -> tuple[Any, Any, Any]:
        from edu.mit.csail.sdg.alloy4 import SafeList  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.ast import Sig  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.parser import CompModule  # type: ignore[import-not-found]

        fields = (Sig.PrimSig.class_.getDeclaredField("children"), SafeList.class_.getDeclaredField("list"),
                  CompModule.class_.getDeclaredField("globals"))
        for f in fields:
            f.setAccessible(True)
        return fields

    def reset(self) -> None:
        """Take away the atoms of the module it served; worlds built on it stop being current."""
        for kids, n in self.children:
            if kids.size() > n:
                kids.subList(n, kids.size()).clear()
        self.globals.clear()
        self.generation += 1


# The analyzer bounds an abstract sig by the union of its children, nested one level per
# child, and reads that union back recursively (A4Solution.query): a sig of 10,000 atoms
# (the hub's slice of a 20,000-component fan-in) overflows the caller's stack. Translation
# runs on a thread of its own with room for that; the stack is virtual memory until used.
BIG_STACK = 512 * 1024 * 1024
_big: dict[str, Any] = {}
_big_lock = threading.Lock()


def on_big_stack(fn: Callable[..., Any], *args: Any) -> Any:
    """`fn(*args)` on this process's big-stack thread (no Python callbacks inside `fn`: the
    caller waits, holding whatever it holds)."""
    from concurrent.futures import ThreadPoolExecutor

    with _big_lock:
        pool = _big.get("pool")
        if pool is None:
            saved = threading.stack_size(BIG_STACK)
            try:
                pool = _big["pool"] = ThreadPoolExecutor(1, thread_name_prefix="reconf-alloy")
                pool.submit(lambda: None).result()   # the thread is made now, with this stack
            finally:
                threading.stack_size(saved)
    return pool.submit(fn, *args).result()


def atom_name(label: str) -> str:
    """An atom of a solution by its sig's name: `this/c_x$0` is `c_x`."""
    label = label.split("/")[-1]
    return label[:-2] if label.endswith("$0") else label


class Backend(Protocol):
    """Everything reconf asks of an Alloy backend: every caller holds one of these (from
    `get_backend`), never a class of its own. `name` says which backend it is; `lock` is held
    while the analyzer is used from more than one thread (evaluation shares it)."""

    name: str
    lock: threading.RLock

    def run(self, modules: Mapping[str, str], main: str, command: str | None = None,
            solver: str = DEFAULT_SOLVER, progress: Callable[[CommandOutcome], None] | None = None,
            constants: bool = False) -> list[CommandOutcome]:
        """Run `command` (every command when None) of module `main`; each outcome."""
        ...

    def commands(self, modules: Mapping[str, str], main: str) -> list[str]:
        """The labels of `main`'s commands, in order."""
        ...

    def solve_module(self, text: str, main: str, exprs: tuple[str, ...] = (), command: str | int = 0,
                     solver: str = DEFAULT_SOLVER) -> Trace:
        """One command of one module, and `exprs` evaluated in every state of its instance."""
        ...

    def bounds(self, modules: Mapping[str, str], main: str) -> dict[str, dict[str, tuple[int, bool]]]:
        """Per command, the most atoms each signature gets, and whether exactly."""
        ...

    def outcomes_of(self, modules: Mapping[str, str], main: str, judged: Mapping[str, tuple[bool, float]],
                    solver: str) -> list[CommandOutcome]:
        """The outcomes of commands judged elsewhere, without solutions."""
        ...

    def usable_solver(self, name: str) -> str:
        """The analyzer's id of the solver that runs when `name` is asked for."""
        ...

    def solver_used(self, name: str) -> str:
        """The table's name of that solver."""
        ...


class AlloyBridge:
    """The in-process backend: the Alloy jar through JPype. Use `AlloyBridge.get()`."""

    name = "alloy-jpype"
    lock: threading.RLock
    _instance: "AlloyBridge | None" = None
    _instance_lock = threading.Lock()

    @classmethod
    def get(cls) -> "AlloyBridge":
        """The bridge, starting the JVM on first use; raises AlloyUnavailable."""
        with cls._instance_lock:
            if cls._instance is None:
                ensure_jvm()
                cls._instance = cls()
            return cls._instance

    def __init__(self) -> None:
        # by name (jvm.java_class), not `from edu... import`: a cold check, whose start waits
        # for this, does not have JPype index the class path
        self._A4Reporter = java_class("edu.mit.csail.sdg.alloy4.A4Reporter")
        self._Err = java_class("edu.mit.csail.sdg.alloy4.Err")
        self._CompUtil = java_class("edu.mit.csail.sdg.parser.CompUtil")
        self._A4Options = java_class("edu.mit.csail.sdg.translator.A4Options")
        self._Translate = java_class("edu.mit.csail.sdg.translator.TranslateAlloyToKodkod")
        self._usable: dict[str, bool] = {}
        self._lock = self.lock = threading.RLock()
        self._skeletons: dict[tuple[str, str, tuple[str, ...]], _Skeleton] = {}

    # -- solvers -------------------------------------------------------------------

    def solver_ids(self) -> list[str]:
        return [str(s.id()) for s in self._A4Options.SatSolver.values()]

    def _solver(self, name: str) -> Any:
        wanted = SOLVER_ALIASES.get(name.lower(), name)
        for s in self._A4Options.SatSolver.values():
            if wanted in (str(s.id()), str(s)) or name.lower() == str(s).lower():
                return s
        known = ", ".join(SOLVER_ALIASES)
        raise AlloyError(f"unknown SAT solver {name!r}; known: {known}")

    def usable_solver(self, name: str) -> str:
        """`name` if its native library loads here, else the pure-Java fallback."""
        with self._lock:
            key = str(self._solver(name).id())
            if key not in self._usable:
                self._usable[key] = self._probe(key)
            return key if self._usable[key] else FALLBACK_SOLVER

    def solver_used(self, name: str) -> str:
        """The table's name of the solver that runs when `name` is asked for: `name`, or the
        fallback when its native library does not load here (what evidence must name)."""
        key = self.usable_solver(name)
        return next((s.name for s in SOLVER_TABLE if s.analyzer == key), key)

    def _probe(self, solver_id: str) -> bool:
        if solver_id == FALLBACK_SOLVER:
            return True
        factory = _SAT_FACTORIES.get(solver_id)
        if factory is not None:
            # Kodkod loads the native library and reports whether it works; no solve needed
            from kodkod.engine.satlab import SATFactory  # type: ignore[import-not-found]

            try:
                return bool(SATFactory.available(getattr(SATFactory, factory)))
            except Exception:
                return False
        try:
            probe = "sig A {}\nrun { some A } for 2 expect 1\n"
            outcomes = self._run_checked({"probe.als": probe}, "probe.als", None, solver_id)
            return bool(outcomes and outcomes[0].satisfiable)
        except Exception:
            return False

    # -- running ---------------------------------------------------------------------

    def _world(self, modules: Mapping[str, str], main: str) -> Any:
        """The parsed modules; their atoms declared through the API are `world.extra_sigs`
        (see `_split_world`), an empty list when the text declares them all."""
        from java.util import HashMap  # type: ignore[import-not-found]

        if main not in modules:
            raise AlloyError(f"main module {main!r} not among the modules given")
        if len(modules) == 1:
            split = split_module(modules[main])
            if split is not None:
                try:
                    return self._split_world(split, main)
                except Exception:  # the front end's own path below reports it, positioned
                    pass
        files = HashMap()
        for name, text in modules.items():
            files.put(VFS + name, text)
        try:
            return _World(self._CompUtil.parseEverything_fromFile(self._A4Reporter(), files, VFS + main), [])
        except self._Err as err:
            raise self._error(err) from None

    def _split_world(self, split: Split, main: str) -> "_World":
        """A large generated module parsed in two parts (`checker.alloy.split`): the
        skeleton as text, then each atom declared as a `one sig` through the API and bound
        by name to a constant of its parent's type, then each body parsed and set."""
        from edu.mit.csail.sdg.alloy4 import Pos  # type: ignore[import-not-found]
        from edu.mit.csail.sdg.ast import Attr, ExprCall, Func, Sig  # type: ignore[import-not-found]
        from java.util import HashMap

        # the hollowed bodies too: an empty body written as the placeholder is not hollowed,
        # and a reused skeleton must have every body it was given replaced
        key = (main, skeleton_key(split.skeleton), tuple(sorted(split.bodies)))
        skeleton = self._skeletons.pop(key, None)
        if skeleton is None:
            files = HashMap()
            files.put(VFS + main, split.skeleton)
            skeleton = _Skeleton(self._CompUtil.parseEverything_fromFile(self._A4Reporter(), files, VFS + main))
        else:
            skeleton.reset()
        world, sigs = skeleton.module, skeleton.sigs
        extra = []
        for atom, parent in split.atoms:
            sig = Sig.PrimSig(Pos.UNKNOWN, "this/" + atom, Pos.UNKNOWN, sigs[parent], Attr.ONE)
            extra.append(sig)
            # typed as its parent: a union of atom products then has one product type
            constant = Func(Pos.UNKNOWN, Pos.UNKNOWN, atom, None, sigs[parent], sig)
            world.addGlobal(atom, ExprCall.make(Pos.UNKNOWN, None, constant, None, 0))
        for name, body in split.bodies.items():
            skeleton.funcs[name].setBody(world.parseOneExpressionFromString(body))
        if skeleton.usable:  # kept only once the module is whole (an error above drops it)
            self._skeletons[key] = skeleton
            while len(self._skeletons) > SKELETONS:
                self._skeletons.pop(next(iter(self._skeletons)))
        return _World(world, extra, skeleton, skeleton.generation)

    def _error(self, err: Any) -> AlloyError:
        pos = err.pos
        module = None
        line = column = 0
        if pos is not None:
            filename = str(pos.filename or "")
            module = filename[len(VFS):] if filename.startswith(VFS) else (filename or None)
            line, column = int(pos.y), int(pos.x)
        return AlloyError(str(err.msg), module, line, column)

    def commands(self, modules: Mapping[str, str], main: str) -> list[str]:
        with self._lock:
            world = self._world(modules, main)
            return [str(c.label) for c in world.module.getAllCommands()]

    def run(self, modules: Mapping[str, str], main: str, command: str | None = None,
            solver: str = DEFAULT_SOLVER,
            progress: Callable[[CommandOutcome], None] | None = None,
            constants: bool = False) -> list[CommandOutcome]:
        """Run every command of `main` (or only the one labelled `command`).

        Falls back to SAT4J when the requested solver's native library does not load.
        `constants` says the module's relations are all constants (instance and plan
        modules): nothing to skolemize, every quantifier folds while translating.
        """
        with self._lock:
            solver_id = self.usable_solver(solver)
            return self._run_checked(modules, main, command, solver_id, progress, constants)

    def _run_checked(self, modules: Mapping[str, str], main: str, command: str | None,
                     solver_id: str,
                     progress: Callable[[CommandOutcome], None] | None = None,
                     constants: bool = False) -> list[CommandOutcome]:
        world = self._world(modules, main)
        commands = list(world.module.getAllCommands())
        if command is not None:
            commands = [c for c in commands if str(c.label) == command]
            if not commands:
                raise AlloyError(f"no command {command!r} in {main}")
        opts = self.options(solver_id)
        if constants:
            opts.skolemDepth = -1  # skolem relations would only add variables to fold away
            # every relation is exact: symmetry breaking removes no solution worth removing,
            # and detecting the symmetries took a fifth of a 1,000-component check's solving
            opts.symmetry = 0
        outcomes = []
        for cmd in commands:
            outcome = self._execute(world, cmd, opts, solver_id)
            if progress is not None:
                progress(outcome)
            outcomes.append(outcome)
        return outcomes

    def solve_module(self, text: str, main: str, exprs: tuple[str, ...] = (), command: str | int = 0,
                     solver: str = DEFAULT_SOLVER) -> Trace:
        """Run one command of the module `text` (by label, or by its place), named `main` in
        errors, and evaluate `exprs` in every state of its instance (all of an Alloy 6
        trace, up to its loop). Errors are the analyzer's, positioned (AlloyError)."""
        with self._lock:
            solver_id = self.usable_solver(solver)
            world = self._world({main: text}, main)
            commands = list(world.module.getAllCommands())
            chosen = ([c for c in commands if str(c.label) == command] if isinstance(command, str)
                      else commands[command:command + 1])
            if not chosen:
                raise AlloyError(f"no command {command!r} in {main}")
            sol, elapsed = self._solve(world, chosen[0], self.options(solver_id))
            if not sol.satisfiable():
                return Trace(False, elapsed)
            states = [{e: self._eval(world, sol, e, state) for e in exprs}
                      for state in range(int(sol.getTraceLength()))]
            return Trace(True, elapsed, states)

    def bounds(self, modules: Mapping[str, str], main: str) -> dict[str, dict[str, tuple[int, bool]]]:
        """For each command of `main`, the most atoms the analyzer gives each signature and
        whether that number is exact, as its scope computer sets them before translating
        (the sigs of opened library modules left out)."""
        from edu.mit.csail.sdg.ast import Command, Sig  # type: ignore[import-not-found]
        from java.lang import Class, Iterable  # type: ignore[import-not-found]

        with self._lock:
            world = self._world(modules, main)
            # the analyzer's scope computer is package-private: reached by reflection
            computer = Class.forName("edu.mit.csail.sdg.translator.ScopeComputer", True,
                                     self._A4Options.class_.getClassLoader())
            compute = computer.getDeclaredMethod(
                "compute", self._A4Reporter.class_, self._A4Options.class_, Iterable.class_, Command.class_)
            most, exact = (computer.getDeclaredMethod(m, Sig.class_) for m in ("sig2scope", "isExact"))
            for m in (compute, most, exact):
                m.setAccessible(True)
            sigs = [s for s in world.sigs()
                    if isinstance(s, Sig.PrimSig) and not s.builtin and str(s.label).startswith("this/")]
            out = {}
            for cmd in world.module.getAllCommands():
                try:
                    scopes = compute.invoke(None, self._A4Reporter(), self.options(DEFAULT_SOLVER),
                                            world.sigs(), cmd).b
                except Exception as err:  # noqa: BLE001 - the analyzer's Err, wrapped by reflection
                    cause = err.getCause() if hasattr(err, "getCause") and err.getCause() is not None else err
                    raise AlloyError(f"the scope of {cmd.label}: {cause}") from None
                out[str(cmd.label)] = {str(s.label).removeprefix("this/"):
                                       (int(most.invoke(scopes, s)), bool(exact.invoke(scopes, s))) for s in sigs}
            return out

    def options(self, solver_id: str) -> Any:
        """The analyzer's options for every command run here: `solver_id`, skolemisation
        depth 1, no integer overflow."""
        opts = self._A4Options()
        opts.solver = self._solver(solver_id)
        opts.skolemDepth = 1
        opts.noOverflow = True
        return opts

    def _execute(self, world: _World, cmd: Any, opts: Any, solver_id: str) -> CommandOutcome:
        if not world.current:  # e.g. a progress callback ran another module on its skeleton
            raise AlloyError("the module was replaced by a later one before all its commands ran")
        sol, elapsed = self._solve(world, cmd, opts)
        satisfiable = bool(sol.satisfiable())
        evaluator = (lambda expr: self._eval(world, sol, expr)) if satisfiable else None
        return self._outcome(cmd, satisfiable, elapsed, solver_id, evaluator)

    def _solve(self, world: _World, cmd: Any, opts: Any) -> tuple[Any, float]:
        """The analyzer's solution of `cmd`, and the seconds it took (translation included)."""
        start = time.perf_counter()
        try:
            sol = on_big_stack(self._Translate.execute_command, self._A4Reporter(), world.sigs(), cmd, opts)
        except self._Err as err:
            raise self._error(err) from None
        return sol, time.perf_counter() - start

    @staticmethod
    def _outcome(cmd: Any, satisfiable: bool, elapsed: float, solver_id: str,
                 evaluator: Callable[[str], Tuples] | None = None) -> CommandOutcome:
        text = str(cmd.toString())
        scope = text.split(" for ", 1)[1] if " for " in text else ""
        if " expect " in scope:
            scope = scope.split(" expect ")[0]
        return CommandOutcome(
            label=str(cmd.label), is_check=bool(cmd.check), expects=int(cmd.expects),
            satisfiable=satisfiable, elapsed=elapsed, solver=solver_id, scope=scope,
            _evaluator=evaluator,
        )

    def outcomes_of(self, modules: Mapping[str, str], main: str, judged: Mapping[str, tuple[bool, float]],
                    solver: str) -> list[CommandOutcome]:
        """The outcomes of the commands of `main` judged elsewhere (another process), as
        {label: (satisfiable, seconds)}, in the module's order, without solutions to evaluate."""
        with self._lock:
            world = self._world(modules, main)
            return [self._outcome(c, *judged[str(c.label)], solver)
                    for c in world.module.getAllCommands() if str(c.label) in judged]

    def _eval(self, world: _World, sol: Any, expr: str, state: int | None = None) -> Tuples:
        """`expr`'s value in `sol` (in trace state `state`, when given)."""
        with self._lock:
            if not world.current:
                raise AlloyError("the solution's module was replaced by a later one: evaluate its expressions "
                                 "before running another module")
            try:
                parsed = self._CompUtil.parseOneExpression_fromString(world.module, expr)
                value = sol.eval(parsed) if state is None else sol.eval(parsed, state)
            except self._Err as err:
                raise self._error(err) from None
            if isinstance(value, bool) or str(type(value)).endswith("Boolean'>"):
                return {("true",)} if bool(value) else set()
            result: Tuples = set()
            for t in value:
                result.add(tuple(str(t.atom(i)) for i in range(t.arity())))
            return result


def get_backend() -> Backend:
    """The Alloy backend, the one way every caller reaches the analyzer: the jar through JPype,
    started on first use. Raises AlloyUnavailable, which says what to install (Java, the jar)
    and that `--engine python` judges without it."""
    return AlloyBridge.get()


__all__ = ["AlloyBridge", "AlloyUnavailable", "Backend", "CommandOutcome", "Trace", "atom_name", "get_backend"]
