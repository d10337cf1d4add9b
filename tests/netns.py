"""Two test hosts on one machine: network namespaces joined by a veth pair, made and removed by the test.

Only addresses inside namespaces this module created are used. Fast DDS runs with the UDP transport
alone (no shared memory), so every byte between the hosts crosses the veth pair, and the pair's
counters show it.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

# A /30 of the private range, used only inside the two namespaces made here and gone at teardown.
SUBNET_PREFIX = "10.213.77"


def _ip(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)


def _must(*args: str) -> None:
    result = _ip(*args)
    if result.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)} failed: {result.stderr.strip()}")


@dataclass
class Host:
    """One namespace: its name, its veth end and its address."""

    namespace: str
    interface: str
    address: str

    def command(self, argv: list[str]) -> list[str]:
        """Return ``argv`` run inside this host's namespace (``ip netns exec`` execs, so the pid is kept)."""
        return ["ip", "netns", "exec", self.namespace, *argv]

    def rx_bytes(self) -> int:
        """Bytes received on this host's veth end."""
        out = subprocess.run(
            self.command(["cat", f"/sys/class/net/{self.interface}/statistics/rx_bytes"]),
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
        return int(out.stdout.strip())


@dataclass
class TwoHosts:
    """Two hosts on a veth pair; ``close`` removes both namespaces (and with them the pair)."""

    a: Host
    b: Host
    made: list[str] = field(default_factory=list)

    def environment(self, domain: int) -> dict[str, str]:
        """Return the environment for ROS processes on either host: UDP only, discovery on the subnet."""
        env = dict(os.environ)
        env.update(
            ROS_DOMAIN_ID=str(domain),
            ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET",
            FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
            PYTHONUNBUFFERED="1",
        )
        env.pop("ROS_STATIC_PEERS", None)
        return env

    def close(self) -> None:
        """Remove every namespace this object made."""
        for namespace in reversed(self.made):
            _ip("netns", "del", namespace)
        self.made.clear()


def can_make_namespaces() -> str:
    """Return why namespaces cannot be made here, or "" when they can."""
    if os.geteuid() != 0:
        return "network namespaces need root (the test creates them with ip netns)"
    if not Path("/usr/sbin/ip").exists() and not Path("/sbin/ip").exists() and not Path("/bin/ip").exists():
        return "the ip command (iproute2) is not installed"
    return ""


def make_two_hosts(tag: str) -> TwoHosts:
    """Create namespaces ``fdr-a-TAG`` and ``fdr-b-TAG`` joined by a veth pair with their own addresses."""
    hosts = TwoHosts(
        Host(f"fdr-a-{tag}", "veth-a", f"{SUBNET_PREFIX}.1"),
        Host(f"fdr-b-{tag}", "veth-b", f"{SUBNET_PREFIX}.2"),
    )
    try:
        for host in (hosts.a, hosts.b):
            _must("netns", "add", host.namespace)
            hosts.made.append(host.namespace)
        _must(
            "link",
            "add",
            "veth-a",
            "netns",
            hosts.a.namespace,
            "type",
            "veth",
            "peer",
            "name",
            "veth-b",
            "netns",
            hosts.b.namespace,
        )
        for host in (hosts.a, hosts.b):
            ns = ["-n", host.namespace]
            _must(*ns, "addr", "add", f"{host.address}/30", "dev", host.interface)
            _must(*ns, "link", "set", "lo", "up")
            _must(*ns, "link", "set", host.interface, "up", "multicast", "on")
            # DDS discovery is multicast; without a route for it the packets have no way out.
            _must(*ns, "route", "add", "224.0.0.0/4", "dev", host.interface)
    except Exception:
        hosts.close()
        raise
    return hosts
