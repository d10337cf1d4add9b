"""The first request of a fresh client: raw rclpy, and the client pattern of docs/cell.md that never loses it.

A server answers a request through its reply writer, which must have matched the client's reply reader;
Fast DDS discovers the two sides of that match independently, and a client's ``wait_for_service`` only
sees its own side. rmw_fastrtps waits a short, fixed time for the server's side, then drops the reply
(rclpy warns "failed to send response (timeout): client will not receive response" in the server's
log; the client hears nothing). Each client here is a process-like fresh participant (its own context),
as an integrator's tool is: it waits for the service, sends an idempotent request (a device's
``get_state``) and, unanswered after RESEND_S, sends it again.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import pytest

CLIENTS = 6
RESEND_S = 0.5  # the pattern's resend interval: far above an answer's few ms, far below a lost one
ANSWER_TIMEOUT_S = 10.0


def _fresh_client_call(domain: int, service: str) -> tuple[int, float]:
    """One fresh participant's first call, with resends: return (requests sent, seconds to the answer)."""
    import rclpy
    from lifecycle_msgs.srv import GetState
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("first_request_client", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        client = node.create_client(GetState, service)
        assert client.wait_for_service(timeout_sec=ANSWER_TIMEOUT_S), f"{service} not discovered"
        started = time.monotonic()
        futures = [client.call_async(GetState.Request())]
        next_send = started + RESEND_S
        while not any(f.done() for f in futures):
            now = time.monotonic()
            assert now - started < ANSWER_TIMEOUT_S, f"no answer within {ANSWER_TIMEOUT_S} s"
            if now >= next_send:
                futures.append(client.call_async(GetState.Request()))  # idempotent: safe to send again
                next_send = now + RESEND_S
            executor.spin_once(timeout_sec=0.01)
        answer = next(f for f in futures if f.done()).result()
        assert answer.current_state.label == "unconfigured"
        return len(futures), time.monotonic() - started
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


@pytest.mark.ros
def test_every_fresh_raw_client_gets_its_first_answer_with_the_resend_pattern(
    ros_domain: int, launch_node: Callable[..., Any]
) -> None:
    device = launch_node(
        "feeder_sim",
        "mems_field_array",
        wait_services=("/mems_field_array/get_state",),
        lifecycle="unconfigured",
    )
    results = [_fresh_client_call(ros_domain, "/mems_field_array/get_state") for _ in range(CLIENTS)]
    # Every client was answered, a lost first reply made good by the resend.
    assert all(seconds < ANSWER_TIMEOUT_S for _, seconds in results), results
    resent = sum(1 for sent, _ in results if sent > 1)
    dropped = device.output().count("client will not receive response")
    print(f"{CLIENTS} fresh clients: {resent} resent, the server dropped {dropped} replies: {results}")
