"""A PLC runs a squeeze plan over OPC UA: the gateway's squeeze_gripper profile against a running gripper.

An independent OPC UA client (asyncua's) calls PlacePart and RunPlan on the gripper's object; the plan's
result shows in the Command variables (two squeezes, the short side read last), and a plan of no squeezes
is a Bad code naming the Angles argument.
"""

from __future__ import annotations

import asyncio
import math
import socket
import time
from pathlib import Path
from typing import Any, Callable

import pytest
from asyncua import Client, ua
from asyncua.ua.uaerrors import UaError

from feeder_cell.gateway import layout

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
NS = "/gws"
KEY = "gws.squeeze_gripper"


def free_port() -> int:
    while True:
        with socket.socket() as sock:
            sock.bind(("127.0.0.1", 0))
            port = sock.getsockname()[1]
        if port != 4840:
            return port


async def connect(url: str, timeout: float = 30.0) -> Client:
    deadline = time.monotonic() + timeout
    while True:
        client = Client(url, timeout=30, watchdog_intervall=10.0)
        try:
            await client.connect()
            return client
        except (OSError, UaError, asyncio.TimeoutError):
            if time.monotonic() > deadline:
                raise AssertionError(f"no OPC UA server on {url} within {timeout:.0f} s") from None
            await asyncio.sleep(0.2)


async def read(client: Client, idx: int, path: str) -> Any:
    return await client.get_node(ua.NodeId(layout.variable_id(KEY, path), idx)).read_value()


async def wait_for(
    client: Client, idx: int, path: str, accept: Callable[[Any], bool], timeout: float = 30.0
) -> Any:
    deadline = time.monotonic() + timeout
    while True:
        node = client.get_node(ua.NodeId(layout.variable_id(KEY, path), idx))
        dv = await node.read_data_value(raise_on_bad_status=False)
        value = dv.Value.Value if dv.Value is not None else None
        if dv.StatusCode.is_good() and accept(value):
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"{path} never accepted within {timeout:.0f} s; last {value!r}")
        await asyncio.sleep(0.05)


async def call(client: Client, idx: int, method: str, *args: ua.Variant) -> ua.CallMethodResult:
    request = ua.CallMethodRequest()
    request.ObjectId = ua.NodeId(KEY, idx)
    request.MethodId = ua.NodeId(layout.method_id(KEY, method), idx)
    request.InputArguments = list(args)
    return (await client.uaclient.call([request]))[0]


def test_a_plc_places_a_part_and_runs_a_plan_over_opc_ua(launch_node: Callable[..., Any]) -> None:
    launch_node(
        "feeder_sim",
        "squeeze_gripper",
        {"part_file": str(ROOT / "examples/squeeze/rectangle.yaml"), "jaw_speed": 0.5, "turn_speed": 30.0},
        namespace=NS,
        wait_topics=(f"{NS}/squeeze_gripper/status",),
    )
    url = f"opc.tcp://127.0.0.1:{free_port()}"
    launch_node("feeder_cell", "opcua_gateway", {"endpoint": url, "devices": [f"{NS}/squeeze_gripper"]})
    plan = [0.0, math.pi / 4]

    async def scenario() -> None:
        client = await connect(url)
        try:
            idx = await client.get_namespace_index(layout.NAMESPACE_URI)
            await wait_for(client, idx, "Status.Ready", lambda v: v is True)
            placed = await call(client, idx, "PlacePart", ua.Variant(2.0, ua.VariantType.Double))
            assert placed.StatusCode.is_good(), placed
            before = await read(client, idx, "Command.ResultCount")
            angles = ua.Variant(plan, ua.VariantType.Double, is_array=True)
            started = await call(client, idx, "RunPlan", angles, ua.Variant(0.0, ua.VariantType.Double))
            assert started.StatusCode.is_good(), started
            await wait_for(client, idx, "Command.ResultCount", lambda n: n > before, 60.0)
            assert await read(client, idx, "Command.LastOutcome") == "DONE"
            assert await read(client, idx, "Command.Result.Squeezes") == 2
            widths = await read(client, idx, "Command.Result.JawWidths")
            assert len(widths) == 2 and widths[-1] == pytest.approx(0.01, abs=1e-9)
            await wait_for(client, idx, "Signals.JawWidth", lambda w: w is not None and w > 0.02)  # opened
            empty = ua.Variant([], ua.VariantType.Double, is_array=True)
            refused = await call(client, idx, "RunPlan", empty, ua.Variant(0.0, ua.VariantType.Double))
            assert refused.StatusCode.value == ua.StatusCodes.BadInvalidArgument, refused
            info = refused.InputArgumentDiagnosticInfos[0].AdditionalInfo or ""
            assert "Angles: a plan needs at least one squeeze" in info, info
        finally:
            await client.disconnect()

    asyncio.run(scenario())
