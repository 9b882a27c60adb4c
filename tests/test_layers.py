"""Every module imports on its own: no import cycle, and no command module that works only
when `checker.cli.main` has been imported first (commands share `checker.cli.common`; `checker.cli.main`
imports the commands to register them)."""
from __future__ import annotations

import pkgutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("reconf_dsl", "checker", "codegen", "reconf_ros")

# One interpreter imports each module after forgetting every module of the project, so a
# module that needs another imported before it fails here.
# Without ROS 2 installed, a runtime module that needs rclpy cannot import: that is not a fault.
SCRIPT = """
import importlib, importlib.util, sys
ros = importlib.util.find_spec("rclpy") is not None
failed = []
for name in sys.argv[1:]:
    for m in [m for m in sys.modules if m.split('.')[0] in {%s}]:
        del sys.modules[m]
    try:
        importlib.import_module(name)
    except ModuleNotFoundError as e:
        if ros or not name.startswith("reconf_ros."):
            failed.append(f"{name}: ModuleNotFoundError: {e}")
    except Exception as e:
        failed.append(f"{name}: {type(e).__name__}: {e}")
print("\\n".join(failed))
""" % ", ".join(repr(p) for p in PACKAGES)


def _modules() -> list[str]:
    out = []
    for pkg in PACKAGES:
        out.append(pkg)
        out += [m.name for m in pkgutil.walk_packages([str(ROOT / pkg)], prefix=pkg + ".")
                if not m.name.endswith("__main__")]
    return out


def test_every_module_imports_alone() -> None:
    modules = _modules()
    assert "checker.gate.change" in modules and "checker.cli.plan_cmd" in modules and "checker.cli.common" in modules
    r = subprocess.run([sys.executable, "-c", SCRIPT, *modules], cwd=ROOT, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "", r.stdout


def test_imports_keep_the_layers() -> None:
    """The import contract of pyproject.toml ([tool.importlinter]; docs/architecture.md): each
    layer of checker imports only from the layers below it, imports inside functions included."""
    lint = Path(sys.executable).with_name("lint-imports")
    r = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "0 broken" in r.stdout and "4 kept" in r.stdout, r.stdout


def test_import_blocks_are_in_one_order() -> None:
    """Standard library, third parties, then reconf's own packages, sorted (`ruff check --select I`,
    configured in pyproject.toml), so a module's imports say at a glance which layers it uses."""
    ruff = Path(sys.executable).with_name("ruff")
    r = subprocess.run([str(ruff), "check", "--select", "I", "--no-cache", "reconf_dsl", "checker", "codegen", "reconf_ros",
                        "bench", "tests"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


# A module name that two modules share, and why they share it (the same idea at two places).
SHARED_NAMES = {
    "semantics.py": "the plan executor's standard-library copy of checker.semantic_model.semantics: the same semantics, "
                    "held equal by tests/test_executor.py",
    "launcher.py": "the two ends of one fork server: its process (reconf_ros/tools) and the client a manager, an "
                   "agent or a plan script talks to it with (reconf_ros/executor, embedded in plan scripts)",
}


def test_module_names_are_unique_where_they_mean_different_things() -> None:
    """One name, one idea: no two modules of the tree share a file name (packages' `__init__`
    and `__main__` aside) unless SHARED_NAMES says why they are the same idea."""
    seen: dict[str, list[str]] = {}
    for pkg in PACKAGES + ("bench",):
        for path in sorted((ROOT / pkg).rglob("*.py*")):
            if path.suffix in (".py", ".pyx") and path.stem not in ("__init__", "__main__"):
                seen.setdefault(path.stem + ".py", []).append(str(path.relative_to(ROOT)))
    shared = {name: paths for name, paths in seen.items() if len(paths) > 1}
    assert set(shared) == set(SHARED_NAMES), f"modules that share a name: {shared}"
