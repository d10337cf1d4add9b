"""Helpers of the load tests: bursts of concurrent calls, a node's RSS, a topic's rate."""

from __future__ import annotations

import threading
import time
from typing import Any

import psutil

from feeder_planner.node_kit.qos import request_qos


def burst_client(client: Any, srv_type: Any, name: str, timeout: float = 30.0) -> Any:
    """Return a client of ``name`` whose reply queue holds a whole burst (the servers' request QoS).

    Cached on the client node: a new client must be discovered before a server can answer it.
    """
    clients = client.__dict__.setdefault("_load_burst_clients", {})
    if (srv_type, name) not in clients:
        clients[(srv_type, name)] = client.create_client(srv_type, name, qos_profile=request_qos())
    service = clients[(srv_type, name)]
    if not service.wait_for_service(timeout_sec=timeout):
        raise AssertionError(f"service {name} not available within {timeout:.0f} s")
    return service


def burst(service: Any, requests: list[Any], timeout: float) -> list[Any]:
    """Send every request at once and return the responses received within ``timeout`` (None: lost)."""
    lock = threading.Lock()
    remaining = [len(requests)]
    done = threading.Event()

    def one_done(_: Any) -> None:
        with lock:
            remaining[0] -= 1
            if remaining[0] == 0:
                done.set()

    futures = []
    for request in requests:
        future = service.call_async(request)
        future.add_done_callback(one_done)
        futures.append(future)
    done.wait(timeout)
    return [f.result() if f.done() else None for f in futures]


def timed_call(service: Any, request: Any, timeout: float) -> tuple[Any, float]:
    """Return (response or None, seconds waited) of one call."""
    start = time.monotonic()
    result = burst(service, [request], timeout)[0]
    return result, time.monotonic() - start


def rss_mb(pid: int) -> float:
    """Return a process's resident set size in MB."""
    return psutil.Process(pid).memory_info().rss / 1e6


def cpu_seconds(pid: int) -> float:
    """Return a process's CPU time so far (user and system, its threads included), in seconds."""
    times = psutil.Process(pid).cpu_times()
    return float(times.user + times.system)
