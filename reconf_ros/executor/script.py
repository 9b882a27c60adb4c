"""A plan script's command line: its options, the dry run, and applying the plan from this
process or through a running manager (docs/executor.md#manager). Exit status: 0 done (or every
state safe), 1 failed, unsafe, stale or violated, 2 usage or no ROS, 130 interrupted (SIGINT or
SIGTERM: docs/executor.md#interrupted)."""
from __future__ import annotations

import argparse
import json
import os
import signal
import sys
from typing import Any, Optional

from .remote import read_hosts
from .replay import replay
from .run import Executor, confirmed
from .steps import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, orphans, plural


def manager_socket(namespace: str = "") -> str:
    """Where the manager of this ROS domain (and namespace) listens by default."""
    base = os.environ.get("XDG_RUNTIME_DIR") or os.path.join("/tmp", f"reconf-{os.getuid()}")
    ns = namespace.strip("/").replace("/", "_")
    return os.path.join(base, "reconf", f"manager-{os.environ.get('ROS_DOMAIN_ID', '0')}{'-' + ns if ns else ''}.sock")


def via_manager(doc: dict[str, Any], argv: list[str], args: argparse.Namespace, path: str) -> int:
    """Have a running manager (`python -m reconf_ros.tools.manager`) apply the plan: it has discovered
    the system already, so no discovery wait here (docs/executor.md#manager). Output streams back."""
    import socket
    if not confirmed(doc, args, sys.stdout):
        return EXIT_FAILED
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(path)
    except OSError as e:
        print(f"no reconf manager at {path} ({e.strerror or e}): start one with `python -m reconf_ros.tools.manager`, "
              "or leave out --manager to apply the plan from this process", file=sys.stderr)
        return EXIT_USAGE
    request = {"doc": doc, "argv": argv + ["--yes", "--quiet-list", "--cwd", os.getcwd()]}

    def forward(signum: int, frame: Any) -> None:
        """A signal to this script asks the manager to stop the run (docs/executor.md#interrupted)."""
        try:
            sock.sendall(json.dumps({"stop": signal.Signals(signum).name}).encode() + b"\n")
        except OSError:
            pass
    with sock, sock.makefile("rwb") as stream:
        stream.write(json.dumps(request).encode() + b"\n")
        stream.flush()
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, forward)
        for line in stream:
            msg = json.loads(line)
            if "exit" in msg:
                return int(msg["exit"])
            print(msg.get("text", ""), end="", file=sys.stderr if msg.get("stream") == "err" else sys.stdout,
                  flush=True)
    print("the reconf manager closed the connection before the plan finished", file=sys.stderr)
    return EXIT_FAILED


def arguments(doc: dict[str, Any]) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=f"Reconfiguration plan for {doc['system']} ({doc['fingerprint']}).")
    ap.add_argument("--dry-run", action="store_true", help="replay the plan against the embedded model; no ROS")
    ap.add_argument("--yes", "-y", action="store_true", help="do not ask for confirmation")
    ap.add_argument("--from-step", type=int, default=1, metavar="N", help="resume at step N (1-based)")
    ap.add_argument("--to-step", type=int, default=0, metavar="N", help="stop after step N (default: the last)")
    ap.add_argument("--timeout", type=float, default=5.0, metavar="S", help="per service call, in seconds")
    ap.add_argument("--step-timeout", type=float, default=30.0, metavar="S", help="per step, in seconds")
    ap.add_argument("--wire-timeout", type=float, default=10.0, metavar="S",
                    help="how long a step waits for the wire (matching, data, assumptions met)")
    ap.add_argument("--discovery-timeout", type=float, default=5.0, metavar="S",
                    help="how long to wait for the plan's running nodes to be discovered")
    ap.add_argument("--pause", type=float, default=0.0, metavar="S",
                    help="wait S seconds after each step but the last, to watch it on the wire (a signal "
                         "stops the run there)")
    ap.add_argument("--one-at-a-time", action="store_true",
                    help="perform every step alone, the steps of the plan's batches too (docs/executor.md#batches)")
    ap.add_argument("--no-launcher", action="store_true",
                    help="start each new node as a Python of its own, not forked from a launcher this script "
                         "starts (docs/executor.md#launcher)")
    ap.add_argument("--no-hold", action="store_true",
                    help="fork each new node at its create step, not ahead, held while the live system is "
                         "checked and the steps before run (docs/executor.md#held)")
    ap.add_argument("--namespace", default="", help="namespace of the components' nodes")
    ap.add_argument("--log-dir", default="", metavar="DIR",
                    help="where started processes write their output (default ./reconf-logs/SYSTEM-TIME-PID)")
    ap.add_argument("--report", default="", metavar="FILE",
                    help="write the run's report (JSON) here; on failure one is always written")
    ap.add_argument("--stop-started", action="store_true",
                    help="on failure, stop the processes this run started (they are named either way)")
    ap.add_argument("--hosts", default="", metavar="FILE",
                    help="a hosts file: each component whose host it names (not \"local\") is started and stopped "
                         "by that host's agent (docs/hosts.md)")
    ap.add_argument("--manager", nargs="?", const="default", default="", metavar="SOCKET",
                    help="let a running reconf manager apply the plan (default socket: this ROS domain's)")
    ap.add_argument("--quiet-list", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--cwd", default="", help=argparse.SUPPRESS)
    return ap


def parse(doc: dict[str, Any], argv: Optional[list[str]],
          ap: Optional[argparse.ArgumentParser] = None) -> argparse.Namespace:
    """The script's arguments, checked (argparse exits with status 2 on bad ones; `reconf up`
    passes a parser of `arguments(doc)` whose errors are its own)."""
    ap = ap or arguments(doc)
    args = ap.parse_args(argv)
    steps = doc["plan"]["steps"]
    if not 1 <= args.from_step <= max(1, len(steps)):
        ap.error(f"--from-step must be between 1 and {max(1, len(steps))}")
    args.to_step = args.to_step or len(steps)
    if steps and not args.from_step <= args.to_step <= len(steps):
        ap.error(f"--to-step must be between --from-step and {len(steps)}")
    if not steps and args.to_step:
        ap.error("--to-step: the plan has no step")
    if min(args.timeout, args.step_timeout, args.wire_timeout, args.discovery_timeout) <= 0:
        ap.error("timeouts must be positive")
    if args.hosts:
        try:
            read_hosts(args.hosts)
        except OSError as e:
            ap.error(f"--hosts: {e.filename or args.hosts}: {e.strerror or e}")
        except ValueError as e:
            ap.error(f"--hosts: {e}")
    return args


def main(doc: dict[str, Any], argv: Optional[list[str]] = None) -> int:
    """The script: replay the plan, then apply it here or through a manager. SIGINT and SIGTERM
    end it quietly (exit 130) until the run takes them over (docs/executor.md#interrupted)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        return _main(doc, argv)
    except KeyboardInterrupt:
        print("interrupted before any step: nothing done", file=sys.stderr)
        return EXIT_INTERRUPTED


def _main(doc: dict[str, Any], argv: Optional[list[str]]) -> int:
    try:
        sys.stdout.reconfigure(errors="replace")  # type: ignore[union-attr]
    except AttributeError:
        pass
    args = parse(doc, argv)
    plan = doc["plan"]
    steps = plan["steps"]
    print(f"plan for {doc['system']} ({doc['fingerprint']}): {plural(len(steps), 'step')}, "
          f"strategy {plan.get('strategy')}, "
          f"disruption {plan.get('disruption')}")
    for key, value in sorted(doc.get("evidence", {}).items()):
        print(f"evidence: {key}: {json.dumps(value, sort_keys=True)}")
    safe = replay(doc, sys.stdout)
    if args.dry_run or not safe:
        if not safe and not args.dry_run:
            print("refusing to apply an unsafe plan", file=sys.stderr)
        return EXIT_OK if safe else EXIT_FAILED
    if not steps and not orphans(doc):
        print("nothing to do: the plan has no step")
        return EXIT_OK
    if args.manager:
        forwarded = [f"--{k.replace('_', '-')}={getattr(args, k)}" for k in (
            "from_step", "to_step", "timeout", "step_timeout", "wire_timeout", "discovery_timeout", "namespace",
            "pause")]
        forwarded += [f"--{k.replace('_', '-')}={os.path.abspath(getattr(args, k))}" for k in ("log_dir", "report", "hosts")
                      if getattr(args, k)]      # the manager writes them: absolute paths
        forwarded += ["--stop-started"] if args.stop_started else []
        return via_manager(doc, forwarded, args,
                           manager_socket(args.namespace) if args.manager == "default" else args.manager)
    import importlib.util
    if importlib.util.find_spec("rclpy") is None:
        print("ROS 2 is not available (no module rclpy): install reconf with its `ros` extra "
              "(pip install 'reconf[ros]'), or source a ROS 2 installation; --dry-run needs neither.", file=sys.stderr)
        return EXIT_USAGE
    return Executor(doc, args).apply(args.from_step)
