"""A live system for tests and benchmarks: real node processes over Fast DDS on loopback, in a
domain of their own, a watcher of their statuses, plan scripts run as a user runs them, and
every process ended by its PID at the end (docs/runtime.md#testing).

    with LiveSystem(tmp_path) as live:
        live.deploy("examples/chatter.arch")
        live.wait_ready(["talker", "listener"])
        res = live.run_plan(script)
        assert live.violations() == {}

With `hosts`, the system runs on a lab of hosts (reconf_ros.tools.netlab): each process on the
host its components name (the others, the watcher and plan scripts on `home`), over the hosts'
network, and `crash`, `partition`, `loss` and `heal` strike a host (docs/hosts.md#testing).
"""
from __future__ import annotations

import ctypes
import importlib.util
import itertools
import json
import os
import re
import select
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from ..nodes.dds import loopback_env
from .netlab import NetLab

__all__ = ["LiveSystem", "TAG", "alive", "domain_id", "environs", "ros_available"]

_COUNTER = itertools.count()
TAG = "RECONF_LIVE_SYSTEM"      # the environment variable that marks a live system's processes


def ros_available() -> bool:
    return importlib.util.find_spec("rclpy") is not None


def _die_with_parent() -> None:
    """In the child: end it (SIGTERM) when the process that started it dies, so a test run that
    is itself killed leaves no node behind (Linux PR_SET_PDEATHSIG)."""
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def faults_towards(text: str, ftm: str) -> Optional[str]:
    """The fault model an architecture (`text`) declares once a transition to `ftm` is due: the
    faults it declares that `ftm` tolerates (the FTM library's); a transition to a mechanism
    that does not tolerate a declared fault is one made when that fault is gone, as the FTM
    rules refuse it while it is declared. None when `ftm` tolerates them all."""
    from checker.ftm.library import all_compositions
    found = re.search(r"^\s*faults ([^\n]*)", text, flags=re.M)
    comp = next((c for c in all_compositions() if str(c) == ftm), None)
    if found is None or comp is None:
        raise ValueError(f"no `faults ...` line, or no mechanism {ftm} in the FTM library")
    declared = [f.strip() for f in found.group(1).split(",")]
    kept = [f for f in declared if f in comp.covers]
    return None if kept == declared else ", ".join(kept)


def alive(pid: int) -> bool:
    """Whether process `pid` runs: a zombie has exited (its parent not told yet, or none that
    reaps it, as for a process whose shell exited)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def environs(name: str) -> dict[int, str]:
    """Each running process's value of environment variable `name`, by PID (those whose
    environment this user may read)."""
    key, found = name.encode() + b"=", {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                pairs = fh.read().split(b"\0")
        except OSError:
            continue
        value = next((p[len(key):] for p in pairs if p.startswith(key)), None)
        if value is not None:
            found[int(entry)] = value.decode(errors="replace")
    return found


def domain_id() -> int:
    """A domain for one live system: one no running process has (a node another session, or an
    earlier system, left would be taken for this one's), distinct within a session, spread across
    sessions, and within RECONF_LIVE_DOMAINS (`LO-HI`, by default 1-100) where sessions that run
    at once are given ranges apart (the Makefile's loopback set and the set beside the host lab)."""
    lo, _, hi = os.environ.get("RECONF_LIVE_DOMAINS", "1-100").partition("-")
    first, last = int(lo), int(hi or lo)
    size, start = last - first + 1, os.getpid() * 7 + next(_COUNTER)
    candidates = [first + (start + k) % size for k in range(size)]
    used = set(environs("ROS_DOMAIN_ID").values())
    return next((d for d in candidates if str(d) not in used), candidates[0])


class LiveSystem:
    def __init__(self, workdir: Path, domain: Optional[int] = None, hosts: Sequence[str] = (),
                 home: str = "") -> None:
        self.dir = Path(workdir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.domain = domain if domain is not None else domain_id()
        bindir = os.path.dirname(sys.executable)
        self.tag = f"{os.getpid()}.{next(_COUNTER)}"      # every process it starts, and theirs, inherits it
        self.env = dict(os.environ, ROS_DOMAIN_ID=str(self.domain), **loopback_env(), **{TAG: self.tag},
                        PATH=bindir + os.pathsep + os.environ.get("PATH", ""), PYTHONUNBUFFERED="1")
        self.env.pop("ROS_LOCALHOST_ONLY", None)
        self.procs: list[subprocess.Popen[Any]] = []
        self.pids: set[int] = set()
        self.status_file = self.dir / "statuses.json"
        self.deployed: list[str] = []
        self.watcher: Optional[subprocess.Popen[bytes]] = None
        self.lab: Optional[NetLab] = None
        self.home = home or (hosts[0] if hosts else "")
        if hosts:
            self.lab = NetLab(list(hosts) + ([home] if home and home not in hosts else [])).up()
            self.env = self.lab.env(self.home, self.env)

    def on_host(self, host: Optional[str], argv: Sequence[str]) -> list[str]:
        """`argv` as run on `host` (default: home) of the lab; as it is without one."""
        if self.lab is None:
            return list(argv)
        return self.lab.argv(host if host and host in self.lab.hosts else self.home, argv)

    # --- processes ---
    def start(self, argv: Sequence[str], log: str, group: Optional[int] = None,
              host: Optional[str] = None) -> subprocess.Popen[bytes]:
        """Start a process in a session of its own, or in process group `group` (0: a new one); on
        `host` of the lab (default: home)."""
        with open(self.dir / log, "ab") as fh:
            proc = subprocess.Popen(self.on_host(host, argv), env=self.env, stdin=subprocess.DEVNULL, stdout=fh,
                                    stderr=subprocess.STDOUT, cwd=self.dir, preexec_fn=_die_with_parent,
                                    start_new_session=group is None, process_group=group)
        self.procs.append(proc)
        self.pids.add(proc.pid)
        return proc

    def expanded(self, arch: str, ftm: Optional[str] = "", name: str = "expanded.arch") -> str:
        """`arch` with every FTM expanded (`reconf ftm expand`), its server's FTM replaced by `ftm`
        first when one is given (None: no FTM), written to the system's directory."""
        from checker.ftm.expand import expand, to_text
        from checker.ftm.library import all_compositions
        from reconf_dsl.ir import FtmDecl
        from reconf_dsl.loader import load
        system = load([arch])
        overrides: dict[str, Optional[FtmDecl]] = {}
        if ftm != "":
            server = next(c for c in system.components if c.ftm is not None)
            assert server.ftm is not None
            comp = next((c for c in all_compositions() if str(c) == ftm), None)
            if ftm is not None and comp is None:
                raise ValueError(f"{ftm!r} is not a composition of the FTM library")
            overrides[server.name] = None if comp is None else FtmDecl(comp.expr(), server.ftm.hosts, server.ftm.span)
        out, _ = expand(system, overrides)
        path = self.dir / name
        path.write_text(to_text(out))
        return str(path)

    def with_ftm(self, arch: str, ftm: str, name: str = "start.arch", faults: Optional[str] = None,
                 towards: Optional[str] = None) -> str:
        """`arch`'s text with its server's mechanism declared as `ftm` (the line `ftm X on ...`)
        and, given `faults`, its fault model as `faults` (the line `faults ...`), written to the
        system's directory: an architecture a transition is planned from. `towards`: the
        mechanism the transition goes to, whose fault model it declares instead (see
        `faults_towards`)."""
        text = Path(arch).read_text(encoding="utf-8")
        if towards is not None:
            faults = faults_towards(text, towards)
        changed, n = re.subn(r"^(\s*ftm )[^\n]*?( on )", lambda m: f"{m.group(1)}{ftm}{m.group(2)}", text,
                             count=1, flags=re.M)
        if n != 1:
            raise ValueError(f"{arch} declares no `ftm ... on ...`")
        if faults is not None:
            changed, n = re.subn(r"^(\s*faults )[^\n]*", lambda m: f"{m.group(1)}{faults}", changed,
                                 count=1, flags=re.M)
            if n != 1:
                raise ValueError(f"{arch} declares no `faults ...`")
        path = self.dir / name
        path.write_text(changed, encoding="utf-8")
        return str(path)

    def serve_ftm(self, arch: str, ftm: Optional[str], hz: float, client: str = "client", count: int = 0
                  ) -> tuple[dict[str, int], Path]:
        """`arch`'s expansion with `ftm` (see `expanded`) deployed one process per host, and once
        every node is up, its demo client in a process of its own sending `count` requests (0: no
        end) at `hz` requests/s (a client started earlier would wait on a service that is not there
        yet); the client's log."""
        path = self.expanded(arch, ftm)
        if self.watcher is None:
            self.watch()            # readiness is read from the statuses
        from ..nodes.ftm.hosts import by_host
        others = [n for names in by_host(path).values() for n in names if n != client]
        procs = self.deploy_by_host(path, others)
        self.wait_ready(others, timeout=90)
        log = self.dir / f"{client}.jsonl"
        self.env.update(RECONF_CLIENT_HZ=str(hz), RECONF_CLIENT_LOG=str(log), RECONF_CLIENT_COUNT=str(count))
        where = next((h for h, names in by_host(path).items() if client in names), None)
        procs[client] = self.start(["reconf-node", "--arch", path, client, "--deployed", path], f"{client}.log",
                                   host=where).pid
        self.deployed.append(client)
        return procs, log

    def injector(self, topic: str, timeout: float = 20.0) -> "Injector":
        """A node of this system's domain (reconf_ros.tools.inject) that publishes JSON documents on
        `topic`, std_msgs/String, volatile, once something subscribes: a fault's injection, a test
        hook's call. Started ahead, so a document is published when it is sent."""
        proc = subprocess.Popen(self.on_host(None, [sys.executable, "-m", "reconf_ros.tools.inject", topic,
                                                    str(timeout)]), env=self.env,
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                cwd=self.dir, text=True, preexec_fn=_die_with_parent, start_new_session=True)
        self.procs.append(proc)
        self.pids.add(proc.pid)
        return Injector(proc, topic, timeout)

    def deploy_by_host(self, arch: str, components: Optional[Sequence[str]] = None) -> dict[str, int]:
        """Start the deployed components of `arch` as it deploys them, one process per host in a
        process group of its own (a host's crash is its group's: `os.killpg`; on a lab, the host's
        namespace: `crash`), by `reconf-node
        --arch`, which runs a component's own code when its run line is a reconf-node factory,
        and a model-driven node otherwise. Host -> process group id."""
        from ..nodes.ftm.hosts import by_host
        hosts = {h: [n for n in names if components is None or n in components] for h, names in by_host(arch).items()}
        hosts = {h: names for h, names in hosts.items() if names}
        self.deployed += [n for names in hosts.values() for n in names]
        path = os.path.abspath(arch)
        return {host: self.start(["reconf-node", "--arch", path, *names, "--deployed", path], f"host-{host}.log",
                                 group=0, host=host).pid for host, names in hosts.items()}

    def deploy(self, arch: str, components: Optional[Sequence[str]] = None, *, group: bool = True,
               generic: bool = False, per_process: int = 0) -> list[subprocess.Popen[bytes]]:
        """Start the deployed components of `arch` as it deploys them (active, attached, normal once
        their assumptions are met): by their `run` lines (model-driven nodes with `generic`), in
        one process when `group`, or in processes of at most `per_process` components."""
        from reconf_dsl.loader import load
        system = load([arch])
        names = list(components) if components is not None else [c.name for c in system.components]
        self.deployed += names
        argvs: list[list[str]] = []
        for name in names:
            comp = system.component(name)
            assert comp is not None, name
            if generic or not comp.run or comp.node is not None:    # a `node` block: its adapter
                argvs.append(["reconf-node", "--arch", os.path.abspath(arch), name])
            else:
                argvs.append(shlex.split(comp.run))
        deployed = ["--deployed", os.path.abspath(arch)]
        heads = {tuple(a[:-1]) for a in argvs}
        if (group or per_process) and len(heads) == 1:
            head = list(heads.pop())
            size = per_process or len(argvs)
            chunks = [argvs[i:i + size] for i in range(0, len(argvs), size)]
            return [self.start(head + [a[-1] for a in chunk] + deployed, f"deployed-{i}.log")
                    for i, chunk in enumerate(chunks)]
        return [self.start(a + deployed, f"deployed-{i}.log") for i, a in enumerate(argvs)]

    def watch(self) -> None:
        self.watcher = self.start([sys.executable, "-m", "reconf_ros.tools.watch", "--out",
                                   str(self.status_file)], "watch.log")

    def watched_violations(self) -> list[str]:
        """The violations the watcher printed as they happened (watch.log), one per line."""
        try:
            return [ln for ln in (self.dir / "watch.log").read_text().splitlines() if ": " in ln]
        except FileNotFoundError:
            return []

    def manager(self, timeout: float = 20.0) -> str:
        """Start a reconf manager for this system; its socket path (pass `--manager PATH` to a plan)."""
        sock, ready = self.dir / "manager.sock", self.dir / "manager.ready"
        self.start([sys.executable, "-m", "reconf_ros.tools.manager", "--socket", str(sock), "--ready-file", str(ready)],
                   "manager.log")
        end = time.monotonic() + timeout
        while not ready.exists():
            if time.monotonic() > end:
                raise TimeoutError(f"the manager did not start within {timeout} s: see {self.dir / 'manager.log'}")
            time.sleep(0.05)
        return str(sock)

    def statuses(self) -> dict[str, Any]:
        try:
            return dict(json.loads(self.status_file.read_text()))
        except (FileNotFoundError, json.JSONDecodeError):
            return {}

    def wait(self, cond: Callable[[dict[str, Any]], bool], timeout: float) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if cond(self.statuses()):
                return True
            time.sleep(0.1)
        return False

    def wait_detectors_armed(self, timeout: float = 30.0) -> bool:
        """Until every crash detector has seen the beats long enough to know their jitter
        (reconf_ros.nodes.ftm.detect): a crash from then on is detected at the learned silence. A system
        without one is armed at once."""
        def armed(st: dict[str, Any]) -> bool:
            states = [s["values"]["app.detector"] for s in st.values() if "app.detector" in s["values"]]
            return all(x == "armed" for x in states)
        return self.wait(armed, timeout)

    def wait_ready(self, components: Optional[Sequence[str]] = None, timeout: float = 20.0) -> None:
        """Until each component (by default, each deployed) reports every functionality normal and
        its assumptions met."""
        components = self.deployed if components is None else components
        def ready(st: dict[str, Any]) -> bool:
            for c in components:
                v = st.get(f"/{c}", {}).get("values", {})
                modes = [x for k, x in v.items() if k.startswith("mode.")]
                wires = [x for k, x in v.items() if k.startswith("wire.")]
                if not modes or any(m != "normal" for m in modes) or any(w.startswith("not met") for w in wires):
                    return False
            return True
        if not self.wait(ready, timeout):
            raise TimeoutError(f"the system did not come up within {timeout} s: {self.statuses()}")

    # --- plans ---
    def plan_script(self, args: Sequence[str], name: str = "plan.py") -> Path:
        out = self.dir / name
        res = subprocess.run([os.path.join(os.path.dirname(sys.executable), "reconf"), "plan", *args,
                              "--no-alloy", "-o", str(out)], capture_output=True, text=True, env=self.env)
        if res.returncode != 0:
            raise RuntimeError(f"reconf plan {' '.join(args)}: {res.stderr}")
        return out

    def run_plan(self, script: Path, *args: str, report: str = "report.json",
                 timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
        res = subprocess.run(self.on_host(None, [sys.executable, str(script), "--yes", "--log-dir",
                                                 str(self.dir / "logs"), "--report", str(self.dir / report), *args]),
                             capture_output=True, text=True, env=self.env, timeout=timeout, cwd=self.dir)
        for info in self.report(report).get("started", {}).values():
            self.pids.add(int(info["pid"]))
        return res

    def report(self, name: str = "report.json") -> dict[str, Any]:
        try:
            return dict(json.loads((self.dir / name).read_text()))
        except FileNotFoundError:
            return {}

    def pid_of(self, component: str, report: str = "report.json") -> int:
        return int(self.report(report)["started"][component]["pid"])

    # --- the oracle ---
    def settle_status(self, components: Sequence[str] = (), timeout: float = 10.0) -> dict[str, Any]:
        """Statuses published after now by each of `components` (each publishes at least once a
        second), and by every other component seen."""
        since = time.time()
        wanted = {f"/{c}" for c in components}
        alive = {n for n, s in self.statuses().items() if s["seen"] > since - 3}   # gone ones stay silent

        def fresh(st: dict[str, Any]) -> bool:
            return all(n in st and st[n]["seen"] > since for n in wanted | alive)
        self.wait(fresh, timeout)
        return self.statuses()

    def violations(self, statuses: Optional[dict[str, Any]] = None) -> dict[str, str]:
        """Components whose monitor saw a normal mode's assumption violated, with its report."""
        st = self.statuses() if statuses is None else statuses
        return {n: s["message"] + (f" (last violation at {s['values']['last_violation']})"
                                   if "last_violation" in s["values"] else "")
                for n, s in st.items() if s["values"].get("violations", "0") != "0"}

    def agents(self) -> Path:
        """Start the per-host agent on every host of the lab (reconf_ros.tools.agent); the hosts
        file a plan takes (`--hosts`) to start each component on its host."""
        assert self.lab is not None, "agents need a lab (LiveSystem(hosts=...))"
        from .netlab import start_agents
        hosts_file, procs = start_agents(self.lab, self.dir / "agents", base=self.env)
        for proc in procs.values():
            self.procs.append(proc)
            self.pids.add(proc.pid)
        return hosts_file

    # --- faults of hosts and links (a lab's) ---
    def crash(self, host: str) -> list[int]:
        """Host `host` crashes: every process on it killed (SIGKILL); their PIDs."""
        assert self.lab is not None, "a host crash needs a lab (LiveSystem(hosts=...))"
        return self.lab.crash(host)

    def partition(self, host: str, how: str = "link") -> None:
        assert self.lab is not None, "a partition needs a lab (LiveSystem(hosts=...))"
        self.lab.partition(host, how)

    def loss(self, host: str, percent: float) -> None:
        assert self.lab is not None, "a loss needs a lab (LiveSystem(hosts=...))"
        self.lab.loss(host, percent)

    def heal(self, host: str) -> None:
        assert self.lab is not None
        self.lab.heal(host)

    # --- the end ---
    def _signal(self, sig: int) -> None:
        for pid in sorted(self.pids):
            for kill in (os.killpg, os.kill):     # its group (a plan's children too), and itself
                try:
                    kill(pid, sig)
                except (ProcessLookupError, PermissionError):
                    pass

    def stop(self) -> None:
        # an injector reads its standard input until it closes (rclpy takes SIGTERM over, and
        # its handler does not end that read): closed, it ends at once instead of at SIGKILL
        for proc in self.procs:
            if proc.stdin is not None:
                try:
                    proc.stdin.close()
                except OSError:
                    pass
        self._signal(signal.SIGTERM)
        end = time.monotonic() + 5
        for proc in self.procs:
            try:
                proc.wait(timeout=max(0.1, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        self._signal(signal.SIGKILL)
        for proc in self.procs:
            if proc.poll() is None:
                proc.wait(timeout=5)
        if self.lab is not None:
            self.lab.down()         # and every process still running on its hosts
        self._end_strays()

    def _end_strays(self) -> None:
        """End every process still running with this system's mark in its environment, by PID: a
        node started by a process the test did not know the PID of (a launcher's child whose
        create line a failed test never read) must not outlive the test into another's domain.
        Says so on stderr: each is a process a test lost track of."""
        signalled = self.pids      # with their process groups: killed already, perhaps not yet gone
        strays = {pid for pid, tag in environs(TAG).items()
                  if tag == self.tag and pid != os.getpid() and pid not in signalled}
        for pid in sorted(strays):
            try:
                if os.getpgid(pid) in signalled:
                    continue
                with open(f"/proc/{pid}/cmdline", "rb") as fh:
                    what = fh.read().replace(b"\0", b" ").decode(errors="replace").strip()
                os.kill(pid, signal.SIGKILL)
            except OSError:         # gone meanwhile (ProcessLookupError is one)
                continue
            print(f"livetest: ended process {pid} ({what[:160]}), left running in domain {self.domain}",
                  file=sys.stderr)

    def __enter__(self) -> "LiveSystem":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.stop()


class Injector:
    """The handle of a reconf_ros.tools.inject process (LiveSystem.injector)."""

    def __init__(self, proc: "subprocess.Popen[str]", topic: str, timeout: float) -> None:
        self.proc, self.topic = proc, topic
        assert proc.stdout is not None and proc.stdin is not None
        self.stdin, self.stdout = proc.stdin, proc.stdout
        self.timeout = timeout
        self.ready = False

    def _line(self, timeout: float) -> str:
        ready, _, _ = select.select([self.stdout], [], [], timeout)
        return self.stdout.readline().strip() if ready else ""

    def wait_ready(self) -> None:
        if not self.ready:
            line = self._line(self.timeout + 20)
            if line != "ready":
                raise RuntimeError(f"nothing subscribes to {self.topic}: {line or 'no answer'}")
            self.ready = True

    def send(self, doc: dict[str, Any]) -> None:
        """Publish `doc` now (waits for the subscriber first if not done yet)."""
        self.wait_ready()
        self.stdin.write(json.dumps(doc) + "\n")
        self.stdin.flush()
        line = self._line(10.0)
        if not line.startswith("sent ") or line == "sent 0":
            raise RuntimeError(f"{self.topic}: {line or 'no answer'} (nothing subscribes any more?)")
