"""The host lab (reconf_ros.tools.netlab) without ROS: hosts are network namespaces with their own
address and machine id on one bridge; datagrams cross between them, and stop crossing when a
host is cut off; loss drops about what it says; a crash kills every process of a host and none
of another's; and a lab is removed whole, also when its owner was killed, while what another
made is left alone. Needs root and iproute2 (skipped otherwise)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from reconf_ros.tools.netlab import ETC_NETNS, RECORDS, NetLab, lab_available, nft_available, sweep

pytestmark = pytest.mark.skipif(lab_available() is not None, reason=f"no host lab here: {lab_available()}")

RECEIVE = """
import socket, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("0.0.0.0", 47000))
s.settimeout(0.2)
print("ready", flush=True)
n, end = 0, time.monotonic() + float(sys.argv[1])
while time.monotonic() < end:
    try:
        s.recv(100)
        n += 1
    except socket.timeout:
        pass
print(n, flush=True)
"""
SEND = """
import socket, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
for i in range(int(sys.argv[2])):
    try:
        s.sendto(b"x", (sys.argv[1], 47000))
    except OSError:
        pass
    time.sleep(0.002)
"""


def namespaces() -> set[str]:
    return set(subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout.split())


def datagrams(lab: NetLab, sender: str, receiver: str, count: int = 300) -> int:
    """How many of `count` datagrams from `sender` reach `receiver`."""
    rx = lab.popen(receiver, [sys.executable, "-c", RECEIVE, "2.5"], stdout=subprocess.PIPE, text=True)
    assert rx.stdout is not None and rx.stdout.readline().strip() == "ready"
    subprocess.run(lab.argv(sender, [sys.executable, "-c", SEND, lab.address(receiver), str(count)]), timeout=30)
    out, _ = rx.communicate(timeout=30)
    return int(out.split()[-1])


def test_hosts_are_network_endpoints_and_a_partition_cuts_one_off() -> None:
    with NetLab(["robot", "station"]) as lab:
        a, b = lab.host("robot"), lab.host("station")
        assert {a.netns, b.netns} <= namespaces() and a.address != b.address
        ids = [lab.popen(h, ["cat", "/etc/machine-id"], stdout=subprocess.PIPE, text=True).communicate()[0]
               for h in ("robot", "station")]
        assert ids[0] != ids[1] and ids[0].strip() != Path("/etc/machine-id").read_text().strip()
        assert datagrams(lab, "robot", "station") == 300
        lab.partition("station")
        assert lab.faults("station") == "link down"
        assert datagrams(lab, "robot", "station") == 0
        lab.heal("station")
        assert datagrams(lab, "robot", "station") == 300
        made = lab.record
    assert not {h.netns for h in made.hosts} & namespaces()
    assert not Path(f"/sys/class/net/{made.bridge}").exists()
    assert not any((ETC_NETNS / h.netns).exists() for h in made.hosts)
    assert not made.path().exists()


@pytest.mark.skipif(nft_available() is not None, reason=str(nft_available()))
def test_loss_and_drops_by_nftables() -> None:
    with NetLab(["robot", "station"]) as lab:
        lab.loss("station", 50)
        got = datagrams(lab, "robot", "station", 400)
        assert 100 < got < 300, got              # about half (binomial: 200 ± 3 sigma = 30)
        lab.partition("station", how="drop")
        assert datagrams(lab, "robot", "station") == 0
        lab.heal("station")
        assert lab.faults("station") == "none"
        assert datagrams(lab, "robot", "station") == 300


def test_a_crash_kills_every_process_of_the_host_and_only_its() -> None:
    with NetLab(["robot", "station"]) as lab:
        doomed = [lab.popen("robot", ["sh", "-c", "sleep 60 & sleep 60 & wait"]) for _ in range(2)]
        spared = lab.popen("station", ["sleep", "60"])
        end = time.monotonic() + 5
        while len(lab.pids("robot")) < 6 and time.monotonic() < end:
            time.sleep(0.05)
        assert len(lab.pids("robot")) == 6
        killed = lab.crash("robot")
        assert len(killed) == 6 and lab.pids("robot") == []
        assert all(p.wait(timeout=5) == -signal.SIGKILL for p in doomed)
        assert spared.poll() is None and lab.pids("station") == [spared.pid]
    assert spared.wait(timeout=5) == -signal.SIGKILL         # the lab's removal ends what runs on it


def test_a_lab_whose_owner_was_killed_is_swept_and_nothing_else() -> None:
    owner = subprocess.Popen([sys.executable, "-c", "import time, sys\nfrom reconf_ros.tools.netlab import NetLab\n"
                              "lab = NetLab(['a', 'b']).up()\nprint(lab.id, flush=True)\ntime.sleep(60)"],
                             stdout=subprocess.PIPE, text=True)
    assert owner.stdout is not None
    lab_id = owner.stdout.readline().strip()
    record = json.loads((RECORDS / f"{lab_id}.json").read_text())
    mine = {h["netns"] for h in record["hosts"]}
    assert mine <= namespaces()
    foreign = f"reconf-zz{os.getpid()}-x"             # our prefix, but no record: not ours to remove
    subprocess.run(["ip", "netns", "add", foreign], check=True)
    try:
        owner.kill()
        owner.wait(timeout=10)
        assert lab_id in sweep()
        assert not mine & namespaces() and foreign in namespaces()
        assert not Path(f"/sys/class/net/{record['bridge']}").exists()
    finally:
        subprocess.run(["ip", "netns", "delete", foreign])


def test_the_command_line(tmp_path: Path) -> None:
    cli = [sys.executable, "-m", "reconf_ros.tools.netlab"]
    lab = f"c{os.getpid() % 100000}"
    up = subprocess.run(cli + ["up", "--hosts", "robot,station", "--lab", lab], capture_output=True, text=True)
    try:
        assert up.returncode == 0, up.stderr
        assert "robot: 10.77.0.1" in up.stdout and "station: 10.77.0.2" in up.stdout
        run = subprocess.run(cli + ["run", "station", "--lab", lab, "--", "sh", "-c",
                                    "echo $RECONF_HOST $FASTDDS_BUILTIN_TRANSPORTS"], capture_output=True, text=True)
        assert run.stdout.split() == ["station", "UDPv4"], run.stderr
        listed = subprocess.run(cli + ["list"], capture_output=True, text=True).stdout
        assert f"lab {lab} (until `down`)" in listed
        again = subprocess.run(cli + ["up", "--hosts", "x", "--lab", lab], capture_output=True, text=True)
        assert again.returncode == 2 and "exists already" in again.stderr
    finally:
        down = subprocess.run(cli + ["down", "--lab", lab], capture_output=True, text=True)
    assert down.returncode == 0 and f"reconf-{lab}-robot" not in namespaces()
    missing = subprocess.run(cli + ["down", "--lab", lab], capture_output=True, text=True)
    assert missing.returncode == 2 and f"no lab named {lab!r}" in missing.stderr
