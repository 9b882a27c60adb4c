"""Hosts on one machine: one Linux network namespace per host, joined by a bridge, each with its
own address and its own machine id, so that the nodes of a host talk to other hosts' nodes over
a real network, and the network can fail (docs/hosts.md#the-host-lab).

    with NetLab(["master", "slave", "client_site"]) as lab:
        proc = lab.popen("master", ["reconf-node", ...], env=lab.env("master"))
        lab.partition("master")          # its link down: a real partition
        lab.heal("master")
        lab.loss("slave", 10)            # 10 % of its packets dropped each way (nftables)
        lab.crash("slave")               # every process of the host killed

    python -m reconf_ros.tools.netlab up examples/ftm/client_server_pbr.arch [--agents]
    python -m reconf_ros.tools.netlab run master -- reconf-node ...
    python -m reconf_ros.tools.netlab down

Everything a lab makes is named with its prefix (namespaces `reconf-<lab>-<host>`, links
`rc<lab>b` and `rc<lab>h<i>`, per-host files under `/etc/netns/<namespace>/`) and written, before
it is made, to a record under RECORDS, so that its removal (`down`, at the end of the `with`
block, at the interpreter's exit, or when a later lab finds its owner dead) removes exactly what
it made and nothing else. Needs root and iproute2; loss and drops need nftables.
"""
from __future__ import annotations

import atexit
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import uuid
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Optional, Sequence

from ..nodes.dds import network_env

__all__ = ["NetLab", "LabHost", "LabError", "lab_available", "nft_available", "sweep", "hosts_of", "main"]

RECORDS = Path("/run/reconf-netlab")     # one JSON record per lab: what it made, who owns it
ETC_NETNS = Path("/etc/netns")           # `ip netns exec` bind-mounts /etc/netns/NS/FILE over /etc/FILE
NETNS_PREFIX = "reconf-"
LINK_PREFIX = "rc"
SUBNET = "10.77.0"                       # each lab is its own segment (its own bridge): no clash
FAULT_TABLE = "reconf_fault"             # the nftables table of a host's injected faults
LAB_ID = re.compile(r"^[a-z0-9]{1,8}$")
_COUNTER = itertools.count()


class LabError(RuntimeError):
    """A command the lab needs failed (the message has its output), or the lab cannot be made here."""


def lab_available() -> Optional[str]:
    """None when labs can be made here; else why not (not root, no `ip`)."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    if shutil.which("ip") is None:
        return "iproute2's `ip` is not installed"
    return None


def nft_available() -> Optional[str]:
    """None when nftables can inject loss and drops; else why not."""
    if shutil.which("nft") is None:
        return "nftables is not installed (`apt-get install nftables`; `make test` installs it where it runs as root)"
    return None


def _run(argv: Sequence[str], stdin: Optional[str] = None, check: bool = True) -> subprocess.CompletedProcess[str]:
    res = subprocess.run(list(argv), input=stdin, capture_output=True, text=True, timeout=30)
    if check and res.returncode != 0:
        raise LabError(f"{' '.join(argv)}: {(res.stderr or res.stdout).strip()}")
    return res


def _start_time(pid: int) -> Optional[str]:
    """The kernel's start time of a process (field 22 of /proc/PID/stat), None when it is gone:
    with the PID it names one process, never a later one that reuses the PID."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rsplit(")", 1)[1].split()[19]


def _base36(n: int) -> str:
    digits = "0123456789abcdefghijklmnopqrstuvwxyz"
    out = ""
    while True:
        n, r = divmod(n, 36)
        out = digits[r] + out
        if n == 0:
            return out


@dataclass
class LabHost:
    """One host of a lab: its namespace, address and the bridge side of its link."""
    name: str
    netns: str
    address: str
    link: str


@dataclass
class Record:
    """What a lab made (or is about to make), and its owner: a process (PID and start time), or
    nobody for a lab `up` made for a user, which stays until `down`."""
    lab: str
    bridge: str
    hosts: list[LabHost] = field(default_factory=list)
    owner_pid: Optional[int] = None
    owner_start: Optional[str] = None

    def path(self) -> Path:
        return RECORDS / f"{self.lab}.json"

    def save(self) -> None:
        RECORDS.mkdir(parents=True, exist_ok=True)
        tmp = self.path().with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(json.dumps(asdict(self), indent=1))
        os.replace(tmp, self.path())

    @staticmethod
    def load(path: Path) -> "Record":
        doc = json.loads(path.read_text())
        hosts = [LabHost(**h) for h in doc.pop("hosts")]
        return Record(hosts=hosts, **doc)

    def orphaned(self) -> bool:
        """Its owner process is gone (a persistent lab has none, and is never orphaned)."""
        return self.owner_pid is not None and _start_time(self.owner_pid) != self.owner_start


def _remove(record: Record) -> None:
    """Remove what `record` lists, whatever of it exists: the processes of its namespaces first
    (a host's processes die with it), then the namespaces, links, bridge, files, the record."""
    existing = set(_run(["ip", "netns", "list"], check=False).stdout.split())
    for h in record.hosts:
        if h.netns in existing:
            _kill_all(h.netns)
            _run(["ip", "netns", "delete", h.netns], check=False)
        if Path(f"/sys/class/net/{h.link}").exists():
            _run(["ip", "link", "delete", h.link], check=False)
        shutil.rmtree(ETC_NETNS / h.netns, ignore_errors=True)
    if Path(f"/sys/class/net/{record.bridge}").exists():
        _run(["ip", "link", "delete", record.bridge], check=False)
    try:
        ETC_NETNS.rmdir()       # only when empty: other namespaces' files are not ours
    except OSError:
        pass
    record.path().unlink(missing_ok=True)


def _pids(netns: str) -> list[int]:
    res = _run(["ip", "netns", "pids", netns], check=False)
    return [int(p) for p in res.stdout.split() if p.isdigit()]


def _kill_all(netns: str, timeout: float = 5.0) -> list[int]:
    """SIGKILL every process of a namespace until none is left (a process forking meanwhile is
    killed at the next round); the PIDs killed."""
    killed: list[int] = []
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        pids = _pids(netns)
        if not pids:
            break
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            except ProcessLookupError:
                pass
        time.sleep(0.02)
    return sorted(set(killed))


def sweep() -> list[str]:
    """Remove every lab whose owner process is gone (a test run that was killed); the labs removed.
    Only what a record lists is touched."""
    removed = []
    for path in sorted(RECORDS.glob("*.json")) if RECORDS.is_dir() else []:
        try:
            record = Record.load(path)
        except (OSError, ValueError, TypeError, KeyError):
            continue
        if record.orphaned():
            _remove(record)
            removed.append(record.lab)
    return removed


class NetLab:
    """A lab of hosts (see the module's docstring). Made by `up()` (or entering the `with`
    block), removed by `down()` (or leaving it, or at the interpreter's exit)."""

    def __init__(self, hosts: Sequence[str], lab: str = "", persistent: bool = False) -> None:
        if len(set(hosts)) != len(hosts) or not hosts or len(hosts) > 250:
            raise LabError(f"a lab needs 1 to 250 distinct hosts, not {list(hosts)}")
        self.id = lab or f"t{_base36(os.getpid())}{_base36(next(_COUNTER))}"
        if not LAB_ID.match(self.id):
            raise LabError(f"a lab's name is 1 to 8 lower-case letters or digits, not {self.id!r}")
        self.persistent = persistent
        self.record = Record(self.id, f"{LINK_PREFIX}{self.id}b")
        for i, name in enumerate(hosts):
            safe = re.sub(r"[^A-Za-z0-9_.-]", "_", name)
            self.record.hosts.append(LabHost(name, f"{NETNS_PREFIX}{self.id}-{safe}", f"{SUBNET}.{i + 1}",
                                             f"{LINK_PREFIX}{self.id}h{i}"))
        self.hosts = {h.name: h for h in self.record.hosts}
        self.made = False

    @classmethod
    def existing(cls, lab: str) -> "NetLab":
        """The lab `up` made under this name (from its record)."""
        try:
            record = Record.load(RECORDS / f"{lab}.json")
        except OSError:
            raise LabError(f"no lab named {lab!r} (`python -m reconf_ros.tools.netlab up ARCH` makes one)") from None
        self = cls([h.name for h in record.hosts], lab, persistent=record.owner_pid is None)
        self.record, self.hosts, self.made = record, {h.name: h for h in record.hosts}, True
        return self

    # --- making and removing ---
    def up(self) -> "NetLab":
        why = lab_available()
        if why:
            raise LabError(why)
        sweep()
        if self.record.path().exists():
            raise LabError(f"a lab named {self.id!r} exists already (`python -m reconf_ros.tools.netlab down "
                           f"--lab {self.id}` removes it)")
        if not self.persistent:
            self.record.owner_pid = os.getpid()
            self.record.owner_start = _start_time(os.getpid())
        self.record.save()                  # before anything is made: a crash midway leaves a record
        self.made = True
        if not self.persistent:
            atexit.register(self.down)
        try:
            self._make()
        except BaseException:
            self.down()
            raise
        return self

    def _make(self) -> None:
        br = self.record.bridge
        _run(["ip", "link", "add", br, "type", "bridge"])
        _run(["ip", "link", "set", br, "up"])
        for h in self.record.hosts:
            _run(["ip", "netns", "add", h.netns])
            etc = ETC_NETNS / h.netns
            etc.mkdir(parents=True, exist_ok=True)
            # a host of its own to DDS: Fast DDS tells hosts apart by /etc/machine-id, and treats
            # participants with the same one as local (shared memory, locators rewritten to
            # 127.0.0.1, which in another namespace reaches nobody)
            (etc / "machine-id").write_text(uuid.uuid4().hex + "\n")
            _run(["ip", "link", "add", h.link, "type", "veth", "peer", "name", "eth0", "netns", h.netns])
            _run(["ip", "link", "set", h.link, "master", br, "up"])
            _run(["ip", "-n", h.netns, "addr", "add", f"{h.address}/24", "dev", "eth0"])
            _run(["ip", "-n", h.netns, "link", "set", "eth0", "up"])
            _run(["ip", "-n", h.netns, "link", "set", "lo", "up"])

    def down(self) -> None:
        """Remove everything the lab made (idempotent)."""
        if self.made:
            self.made = False
            _remove(self.record)
        try:
            atexit.unregister(self.down)
        except Exception:
            pass

    def __enter__(self) -> "NetLab":
        return self.up()

    def __exit__(self, *exc: Any) -> None:
        self.down()

    # --- running on a host ---
    def host(self, name: str) -> LabHost:
        try:
            return self.hosts[name]
        except KeyError:
            raise LabError(f"the lab has no host {name!r} (hosts: {', '.join(self.hosts)})") from None

    def address(self, name: str) -> str:
        return self.host(name).address

    def env(self, name: str, base: Optional[dict[str, str]] = None) -> dict[str, str]:
        """An environment for a process on host `name`: `base` (default: this one) with the DDS
        set-up across hosts (reconf_ros.nodes.dds.network_env) instead of the loopback one."""
        env = dict(os.environ if base is None else base)
        for key in ("FASTDDS_DEFAULT_PROFILES_FILE", "ROS_LOCALHOST_ONLY"):
            env.pop(key, None)
        env.update(network_env())
        env["RECONF_HOST"] = name
        return env

    def argv(self, name: str, argv: Sequence[str]) -> list[str]:
        """`argv` run on host `name` (`ip netns exec` execs it: the PID is the program's)."""
        return ["ip", "netns", "exec", self.host(name).netns, *argv]

    def popen(self, name: str, argv: Sequence[str], **kwargs: Any) -> "subprocess.Popen[Any]":
        return subprocess.Popen(self.argv(name, argv), **kwargs)

    def pids(self, name: str) -> list[int]:
        """The processes running on host `name`."""
        return _pids(self.host(name).netns)

    # --- faults ---
    def crash(self, name: str) -> list[int]:
        """The host crashes: every process of its namespace killed (SIGKILL); their PIDs."""
        return _kill_all(self.host(name).netns)

    def partition(self, name: str, how: str = "link") -> None:
        """Cut host `name` off from every other: its link down (`link`, a cable pulled), or every
        packet on its link dropped both ways by nftables (`drop`)."""
        if how == "link":
            _run(["ip", "link", "set", self.host(name).link, "down"])
        elif how == "drop":
            self._faults(name, "drop")
        else:
            raise LabError(f"a partition is `link` or `drop`, not {how!r}")

    def loss(self, name: str, percent: float) -> None:
        """Drop `percent` % of the packets on host `name`'s link, each way, at random (nftables'
        `numgen random`); 0 ends it."""
        if not 0 <= percent <= 100:
            raise LabError(f"a loss is between 0 and 100 %, not {percent}")
        per_mille = int(round(percent * 10))
        self._faults(name, f"numgen random mod 1000 < {per_mille} drop" if per_mille else "")

    def heal(self, name: str) -> None:
        """Every fault of host `name`'s link ended: the link up, no packet dropped."""
        _run(["ip", "link", "set", self.host(name).link, "up"])
        self._faults(name, "")

    def _faults(self, name: str, verdict: str) -> None:
        """Replace host `name`'s nftables fault table by one applying `verdict` to the packets on
        its link each way (none: no table)."""
        netns = self.host(name).netns
        _run(["ip", "netns", "exec", netns, "nft", "delete", "table", "inet", FAULT_TABLE], check=False)
        if not verdict:
            return
        why = nft_available()
        if why:
            raise LabError(why)
        rules = (f"table inet {FAULT_TABLE} {{\n"
                 f"  chain input {{ type filter hook input priority 0; policy accept; iifname \"eth0\" {verdict}; }}\n"
                 f"  chain output {{ type filter hook output priority 0; policy accept; oifname \"eth0\" {verdict}; }}\n"
                 "}\n")
        _run(["ip", "netns", "exec", netns, "nft", "-f", "-"], stdin=rules)

    def faults(self, name: str) -> str:
        """What is done to host `name`'s link now, in words."""
        h = self.host(name)
        up = "UP" in _run(["ip", "link", "show", h.link]).stdout.split(">")[0]
        table = _run(["ip", "netns", "exec", h.netns, "nft", "list", "table", "inet", FAULT_TABLE], check=False)
        rule = re.search(r'iifname "eth0" (.+)', table.stdout) if table.returncode == 0 else None
        said = [] if up else ["link down"]
        said += [rule.group(1).strip()] if rule else []
        return ", ".join(said) or "none"


def start_agents(lab: NetLab, directory: Path, base: Optional[dict[str, str]] = None, timeout: float = 30.0,
                 detach: bool = False) -> tuple[Path, dict[str, "subprocess.Popen[bytes]"]]:
    """Start the per-host agent (reconf_ros.tools.agent) on every host of `lab`, with a fresh
    token, logs under `directory`/HOST, and write `directory`/hosts.json naming each; the hosts
    file and the agents' processes, once each listens. `detach`: the agents outlive this process
    (a lab `up` made; `down` ends them with the hosts)."""
    from ..executor.remote import AGENT_PORT
    directory.mkdir(parents=True, exist_ok=True)
    token = directory / "agent.token"
    token.write_text(uuid.uuid4().hex + uuid.uuid4().hex + "\n")
    token.chmod(0o600)
    procs: dict[str, subprocess.Popen[bytes]] = {}
    for name, h in lab.hosts.items():
        ready = directory / f"agent-{name}.ready"
        ready.unlink(missing_ok=True)
        argv = [sys.executable, "-m", "reconf_ros.tools.agent", "--host", name, "--listen",
                f"{h.address}:{AGENT_PORT}", "--token-file", str(token), "--log-dir", str(directory / name),
                "--ready-file", str(ready)]
        with open(directory / f"agent-{name}.log", "ab") as log:
            procs[name] = lab.popen(name, argv, env=lab.env(name, base), stdin=subprocess.DEVNULL, stdout=log,
                                    stderr=subprocess.STDOUT, start_new_session=detach)
    end = time.monotonic() + timeout
    for name, proc in procs.items():
        while not (directory / f"agent-{name}.ready").exists():
            if proc.poll() is not None or time.monotonic() > end:
                raise LabError(f"the agent of host {name} did not start: see {directory / f'agent-{name}.log'}")
            time.sleep(0.05)
    hosts = directory / "hosts.json"
    hosts.write_text(json.dumps({"hosts": {n: f"{h.address}:{AGENT_PORT}" for n, h in lab.hosts.items()},
                                 "token_file": token.name}, indent=1) + "\n")
    return hosts, procs


def hosts_of(paths: Sequence[str]) -> list[str]:
    """The hosts an architecture names, in order: declared ones, components' and FTMs' replicas'."""
    from reconf_dsl.loader import load
    system = load(list(paths))
    names: list[str] = [h.name for h in system.hosts]
    for comp in system.components + system.versions:
        names += [comp.host] if comp.host else []
        names += list(comp.ftm.hosts) if comp.ftm is not None else []
    return list(dict.fromkeys(names))


CLI_HELP = """commands (root):
  up ARCH... | --hosts A,B   make a lab with one host per host the architecture names; it stays until `down`;
                             with --agents DIR, an agent on each host and DIR/hosts.json for plans (--hosts)
  down                       remove it (and every process running on its hosts)
  list                       the labs, their hosts, addresses and faults
  run HOST -- CMD...         run CMD on HOST, with the DDS set-up across hosts
  crash HOST                 kill every process of HOST
  partition HOST [--drop]    cut HOST off: its link down (or every packet dropped, nftables)
  loss HOST PERCENT          drop PERCENT % of HOST's packets each way (nftables)
  heal HOST                  end every fault of HOST's link"""


def _cli_up(args: Any) -> int:
    hosts = [h for h in args.hosts.split(",") if h] if args.hosts else hosts_of(args.arch)
    if not hosts:
        raise LabError("the architecture names no host (give `host NAME` to its components, or --hosts A,B)")
    lab = NetLab(hosts, args.lab, persistent=True).up()
    print(f"lab {lab.id}: {len(hosts)} hosts on bridge {lab.record.bridge}")
    for h in lab.record.hosts:
        print(f"  {h.name}: {h.address} (namespace {h.netns})")
    if args.agents:
        try:
            hosts_file, _ = start_agents(lab, Path(args.agents).resolve(), detach=True)
        except (LabError, OSError):
            lab.down()
            raise
        print(f"an agent on each host; plans start components on their hosts with --hosts {hosts_file}")
    print(f"run a command on a host: python -m reconf_ros.tools.netlab run {hosts[0]} -- COMMAND")
    return 0


def _cli_list(args: Any) -> int:
    for path in sorted(RECORDS.glob("*.json")) if RECORDS.is_dir() else []:
        record = Record.load(path)
        owner = "until `down`" if record.owner_pid is None else f"owned by pid {record.owner_pid}"
        print(f"lab {record.lab} ({owner}{', owner gone' if record.orphaned() else ''})")
        lab = NetLab.existing(record.lab)
        for h in record.hosts:
            print(f"  {h.name}: {h.address} (namespace {h.netns}), {len(lab.pids(h.name))} processes, "
                  f"faults: {lab.faults(h.name)}")
    return 0


def _cli_host(args: Any) -> int:
    lab = NetLab.existing(args.lab)
    if args.command == "run":
        cmd = args.rest[1:] if args.rest[:1] == ["--"] else args.rest
        if not cmd:
            raise LabError("say what to run: run HOST -- COMMAND...")
        os.execvpe("ip", lab.argv(args.host, cmd), lab.env(args.host))
    if args.command == "crash":
        print(f"{args.host}: killed {len(lab.crash(args.host))} processes")
    elif args.command == "partition":
        lab.partition(args.host, "drop" if args.drop else "link")
    elif args.command == "loss":
        lab.loss(args.host, float(args.rest[0]) if args.rest else -1.0)
    elif args.command == "heal":
        lab.heal(args.host)
    print(f"{args.host}: faults: {lab.faults(args.host)}")
    return 0


def main(argv: Optional[list[str]] = None) -> int:
    """The command line (CLI_HELP). Exit 0 done, 2 a usage error or a lab that cannot be made."""
    import argparse
    ap = argparse.ArgumentParser(prog="python -m reconf_ros.tools.netlab", description=__doc__.split("\n\n")[0],
                                 epilog=CLI_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["up", "down", "list", "run", "crash", "partition", "loss", "heal"])
    ap.add_argument("arch", nargs="*", help="up: the architecture's files; the others: HOST and their arguments")
    ap.add_argument("--lab", default="lab", help="the lab's name (default: lab)")
    ap.add_argument("--hosts", default="", help="up: these hosts (comma-separated) instead of an architecture's")
    ap.add_argument("--drop", action="store_true", help="partition: drop every packet instead of the link down")
    ap.add_argument("--agents", default="", metavar="DIR", help="up: start an agent on each host, write DIR/hosts.json")
    args, rest = ap.parse_known_args(argv)
    try:
        if args.command == "up":
            return _cli_up(args)
        if args.command == "down":
            NetLab.existing(args.lab).down()
            print(f"lab {args.lab} removed")
            return 0
        if args.command == "list":
            return _cli_list(args)
        if not args.arch:
            ap.error(f"{args.command} needs a HOST")
        args.host, args.rest = args.arch[0], args.arch[1:] + rest
        return _cli_host(args)
    except (LabError, OSError) as e:
        print(f"netlab: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
