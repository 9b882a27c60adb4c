"""`reconf-node`: run components as lifecycle nodes, or print them as `.arch` text.

    reconf-node reconf_ros.demo.chatter:talker            a Component from a factory
    reconf-node --arch robot.arch motor_controller        a model-driven node (reconf_ros.nodes.generic)
    reconf-node --plan plan.json 'X@new'                  a component of the architecture a plan reaches
    reconf-node ... --deployed robot.arch                 start as that architecture deploys it
    reconf-node ... --describe                            print the model, run nothing
    reconf-node --lean ...                                only the control interface's services

Several components in one command share one process (and one DDS participant). Everything
after `--ros-args` goes to ROS (`-r __ns:=/robot`). See docs/runtime.md.
"""
from __future__ import annotations

import importlib
import os
import shlex
import sys
from typing import TYPE_CHECKING, Any, Optional

import click

from ..executor.status import HOLD_FD_ENV
from ..nodes.api import Component, DeclarationError, components_to_arch

if TYPE_CHECKING:
    from reconf_dsl.ir import System
    from reconf_dsl.loader import Sources


def _factory(target: str) -> Component:
    module, _, attr = target.partition(":")
    if not attr:
        raise click.UsageError(f"{target!r}: say MODULE:FACTORY, e.g. reconf_ros.demo.chatter:talker")
    try:
        made = getattr(_import(module), attr)
    except (ImportError, AttributeError) as e:
        raise click.UsageError(f"cannot load {target}: {e}") from None
    comp = made() if callable(made) else made
    if not isinstance(comp, Component):
        raise click.UsageError(f"{target} is not a Component (nor makes one)")
    if comp.run is None:
        comp.run = f"reconf-node {target}"
    return comp


def _import(module: str) -> Any:
    """`module`, from the installed packages, else from the current directory, as `python -m`
    finds it: a node module next to the architecture, where a plan or `reconf up` is run."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as e:
        here = os.getcwd()
        if e.name != module.split(".")[0] or here in sys.path:
            raise
        sys.path.append(here)
        return importlib.import_module(module)


def _node_remap(ros_args: list[str]) -> tuple[Optional[str], list[str]]:
    """The node's name a `-r __node:=NAME` among the ROS arguments gives, and the arguments
    without it: the component takes the name itself, since rcl's remap rules refuse a name with
    `__` in it (a replica's copy, `server__r1_app`)."""
    for i, arg in enumerate(ros_args[:-1]):
        if arg in ("-r", "--remap") and ros_args[i + 1].startswith("__node:="):
            return ros_args[i + 1].split(":=", 1)[1], ros_args[:i] + ros_args[i + 2:]
    return None, ros_args


def _from_architecture(system: "System", name: str) -> Component:
    """A component of the architecture: its own code when its run line is a `reconf-node`
    factory (named as the architecture names it, e.g. a replica's copy), an adapter of the node
    its run line starts when it has a `node` block (docs/adapter.md), else model-driven."""
    ir = system.component(name)
    if ir is not None and ir.node is not None:
        from ..nodes.adapter import from_architecture as adapted
        return adapted(system, name)
    argv = shlex.split(ir.run) if ir is not None and ir.run else []
    if len(argv) >= 2 and argv[0] == "reconf-node" and ":" in argv[1]:
        comp = _factory(argv[1])
        comp.name, comp.host = name, ir.host if ir is not None else None
        return comp
    from ..nodes.generic import from_architecture
    return from_architecture(system, name)


_LOADED: dict[str, tuple["System", dict[str, str]]] = {}     # path -> system, and the text of each file read


def load_cached(path: str, sources: "Optional[Sources]" = None) -> "System":
    """The architecture at `path`, parsed again only when a file it was read from has changed
    (a launcher parses it before it forks, docs/executor.md#launcher). Raises DiagnosticError."""
    # Imported here, not at the top: a node a plan starts (MODULE:FACTORY) needs none of it, and
    # its start-up competes for the CPU with the nodes already running.
    from reconf_dsl.loader import Sources, load
    key = os.path.realpath(path)
    if key in _LOADED and all(_text(f) == t for f, t in _LOADED[key][1].items()):
        return _LOADED[key][0]
    sources = sources if sources is not None else Sources()
    system = load([path], sources)
    _LOADED[key] = system, {os.path.abspath(f): t for f, t in sources.texts.items()}
    return system


def _text(path: str) -> Optional[str]:
    try:
        with open(path, "rb") as fh:
            return fh.read().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return None


_PLANS: dict[str, tuple["System", dict[str, Any]]] = {}


def plan_target(path: str) -> tuple["System", dict[str, Any]]:
    """The architecture a plan document reaches, and the document (a plan's documents are named
    by their content: read once)."""
    import json

    from codegen.ros2 import system_at
    key = os.path.realpath(path)
    if key not in _PLANS:
        try:
            with open(path, encoding="utf-8") as fh:
                doc = json.load(fh)
            _PLANS[key] = system_at(doc), doc
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise click.UsageError(f"{path}: not a plan document reconf can read ({e!r})") from None
    return _PLANS[key]


def _from_plan(path: str, name: str) -> Component:
    """Component `name` (`X@new` or X) as the plan's target has it, or, for one the target no
    longer has, as the last state with it has it."""
    from codegen.ros2 import system_at

    from ..executor.plan_states import PlanStates
    system, doc = plan_target(path)
    renames: dict[str, str] = doc["plan"].get("renames", {})
    if system.component(renames.get(name, name)) is None:
        last = max((i for i, st in enumerate(PlanStates(doc["plan"])) if name in st.components), default=None)
        if last is None:
            raise click.UsageError(f"{path}: the plan has no component {name}")
        system = system_at(doc, last)
    return _from_architecture(system, renames.get(name, name))


def _load(path: str) -> "System":
    from checker.reports.report import render_text
    from reconf_dsl.diagnostics import DiagnosticError
    from reconf_dsl.loader import Sources
    sources = Sources()
    try:
        return load_cached(path, sources)
    except DiagnosticError as e:
        render_text(e.diagnostics, sources, sys.stderr)
        sys.exit(2)


@click.command(context_settings={"help_option_names": ["-h", "--help"], "ignore_unknown_options": True})
@click.argument("targets", nargs=-1)
@click.option("--arch", "arch", type=click.Path(dir_okay=False, exists=True),
              help="TARGETS are components of this architecture, run as model-driven nodes")
@click.option("--plan", "plan_file", type=click.Path(dir_okay=False, exists=True),
              help="TARGETS are components of the architecture this plan document (JSON) reaches, run as "
                   "model-driven nodes (how a plan starts a component that has no run line)")
@click.option("--deployed", type=click.Path(dir_okay=False, exists=True),
              help="start active, attached as this architecture deploys the components; each functionality "
                   "turns normal once its assumptions are met on the wire")
@click.option("--as", "as_name", metavar="NAME",
              help="the component's name (one TARGET only), when it is not TARGET's")
@click.option("--node", "node_name", metavar="NAME",
              help="the node's name (one TARGET only), when it is not the component's: a new version running "
                   "beside its old one (docs/executor.md#names)")
@click.option("--describe", is_flag=True, help="print the components as .arch text and exit (no ROS needed)")
@click.option("--system", "system_name", help="with --describe: start the text with `system NAME`")
@click.option("--gap-factor", type=float, default=1.5, show_default=True,
              help="the monitor's tolerance: an input assuming r Hz is met while messages arrive within k/r s")
@click.option("--dds-env", is_flag=True,
              help="print the shell exports of reconf's DDS set-up (UDP on the loopback, docs/runtime.md#dds) "
                   "and exit: eval \"$(reconf-node --dds-env)\"")
@click.option("--lean", is_flag=True,
              help="serve only the control interface's four services (docs/runtime.md#cost): less CPU per node, "
                   "nothing for tools that list transitions or parameters")
def main(targets: tuple[str, ...], arch: Optional[str], plan_file: Optional[str], deployed: Optional[str],
         as_name: Optional[str], node_name: Optional[str], describe: bool,
         system_name: Optional[str], gap_factor: float, dds_env: bool, lean: bool) -> None:
    """Run TARGETS (MODULE:FACTORY, or component names with --arch) as lifecycle nodes."""
    if dds_env:
        from ..nodes.dds import loopback_env
        for key, value in loopback_env().items():
            click.echo(f"export {key}={shlex.quote(value)}")
        return
    if not targets:
        raise click.UsageError("Missing argument 'TARGETS...': name the components to run")
    argv = list(targets)
    ros_args: list[str] = []
    if "--ros-args" in argv:
        i = argv.index("--ros-args")
        argv, ros_args = argv[:i], argv[i:]
    try:
        if arch:
            system = _load(arch)
            comps = [_from_architecture(system, name) for name in argv]
        elif plan_file:
            comps = [_from_plan(plan_file, name) for name in argv]
        else:
            comps = [_factory(t) for t in argv]
            renamed, rest = _node_remap(ros_args)
            if renamed and len(comps) == 1:      # `--ros-args -r __node:=NAME`: the component is NAME
                comps[0].name, ros_args = renamed, rest
    except (DeclarationError, KeyError) as e:
        raise click.UsageError(str(e)) from None
    if as_name or node_name:
        if len(comps) != 1:
            raise click.UsageError("--as and --node name one component; give one TARGET")
        comps[0].name = as_name or comps[0].name
        comps[0].node_name = node_name
    if describe:
        click.echo(components_to_arch(comps, system_name), nl=False)
        return
    plan: Optional[dict[str, dict[str, list[str]]]] = None
    if deployed:
        system = _load(deployed)
        plan = {c.name: {p.name: [] for p in c.ports} for c in comps}
        for conn in system.connectors:
            for r in conn.roles:
                if r.component in plan:
                    plan[r.component].setdefault(r.port, []).append(conn.name)
    options: dict[str, Any] = {"args": [sys.argv[0]] + ros_args, "deployed": plan, "gap_factor": gap_factor,
                               "lean": lean}
    from ..nodes.component import run_components, wait_release
    hold = os.environ.pop(HOLD_FD_ENV, None)      # a held process (docs/executor.md#held)
    if any(c.wraps is not None for c in comps):         # an adapter's node starts its node's process first
        from ..nodes.adapter import run_nodes
        if hold is not None and not wait_release(int(hold), comps):
            sys.exit(0)
        sys.exit(run_nodes(comps, **options))
    sys.exit(run_components(comps, hold=None if hold is None else int(hold), **options))


if __name__ == "__main__":
    main()
