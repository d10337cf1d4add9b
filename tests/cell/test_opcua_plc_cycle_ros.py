"""A PLC runs the production cell over OPC UA alone: bring-up, three cycles, a fault and its recovery.

The scene is ``feeder_cell/scenes/plc_cell.yaml`` (the cell's devices, unconfigured, and the gateway), run
by ``feeder launch`` on a domain of its own and ended by pid. The client is a plain OPC UA client (asyncua's)
that knows nothing of ROS: it brings each device up with PackML Reset, runs the cycle the reference
controller runs (orient on the array, infeed and feed on the arm, tilt the fixture and back) with methods,
watches every device's PackML state by subscription, and in the second cycle injects a motor fault into the
arm and recovers it the standard's way (Aborted -> Clearing -> Stopped -> Resetting -> Idle).
"""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import ros_harness
from asyncua import Client, ua
from asyncua.ua.uaerrors import UaError

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell/scenes/plc_cell.yaml"
NAMESPACE_URI = "urn:feeder:cell"
ARM, MEMS, FIXTURE = "cell.throwing_arm", "cell.mems_field_array", "cell.assembly_fixture"
DEVICES = (ARM, MEMS, FIXTURE)
TILT, HOME = [-0.5, 0.0, -0.8660254037844386], [0.0, 0.0, -1.0]  # the cell scene's route, gravity

pytestmark = pytest.mark.ros


def _free_port() -> int:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@pytest.fixture(scope="module")
def plc_cell() -> Iterator[str]:
    """The PLC cell scene on a lockstep cell clock as fast as it goes; yields the gateway's URL."""
    lease = ros_harness.DomainLease()
    url = f"opc.tcp://127.0.0.1:{_free_port()}"
    env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    launch = subprocess.Popen(
        [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(SCENE), "--real-time-factor", "max"]
        + ["--set", f"opcua_gateway.endpoint={url}"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    nodes: list[int] = []
    try:
        asyncio.run(_wait_until_serving(url, launch))
        nodes = ros_harness.launched_node_pids(launch.pid)
        yield url
    finally:
        if launch.poll() is None:
            launch.send_signal(signal.SIGINT)
        try:
            output, _ = launch.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            launch.kill()
            output, _ = launch.communicate()
        for pid in nodes:  # every node ended by its pid, whatever the launch did
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        lease.release()
        assert launch.returncode == 0, output[-3000:]


async def _wait_until_serving(url: str, launch: subprocess.Popen[str], timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while True:
        if launch.poll() is not None:
            raise AssertionError(f"the launch ended (exit {launch.returncode}) before the gateway served")
        client = Client(url, timeout=5, watchdog_intervall=10.0)
        try:
            await client.connect()
            await client.disconnect()
            return
        except (OSError, UaError, asyncio.TimeoutError):
            if time.monotonic() > deadline:
                raise AssertionError(f"no OPC UA server on {url} within {timeout:.0f} s") from None
            await asyncio.sleep(0.3)


def u32(value: int) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.UInt32)


def i32(value: int) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Int32)


def dbl(value: float) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Double)


def dbls(values: list[float]) -> ua.Variant:
    return ua.Variant(values, ua.VariantType.Double)


def text(value: str) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.String)


def boolean(value: bool) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Boolean)


class States:
    """Every PackML state change of every device, as a subscription delivers them."""

    def __init__(self) -> None:
        self.seen: dict[str, list[str]] = {key: [] for key in DEVICES}
        self.keys: dict[Any, str] = {}

    def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
        self.seen[self.keys[node.nodeid]].append(value)

    def since(self, key: str, mark: int) -> list[str]:
        return self.seen[key][mark:]


class Plc:
    """What a PLC program does here: method calls, reads, and waits on subscribed states."""

    def __init__(self, client: Client, idx: int, states: States) -> None:
        self.client, self.idx, self.states = client, idx, states

    async def read(self, key: str, path: str) -> Any:
        node = self.client.get_node(ua.NodeId(f"{key}.{path}", self.idx))
        return (await node.read_data_value(raise_on_bad_status=False)).Value.Value

    async def call(self, key: str, method: str, *args: ua.Variant) -> tuple[int, str]:
        request = ua.CallMethodRequest()
        request.ObjectId = ua.NodeId(key, self.idx)
        request.MethodId = ua.NodeId(f"{key}.{method}", self.idx)
        request.InputArguments = list(args)
        result = (await self.client.uaclient.call([request]))[0]
        return result.StatusCode.value, result.OutputArguments[0].Value

    async def good(self, key: str, method: str, *args: ua.Variant) -> str:
        code, message = await self.call(key, method, *args)
        assert code == ua.StatusCodes.Good, f"{key}.{method}: {ua.StatusCode(code).name}: {message}"
        return message

    async def state(self, key: str, *wanted: str, timeout: float = 60.0) -> None:
        """Wait until the subscription has delivered one of ``wanted`` as the device's latest PackML state."""
        deadline = time.monotonic() + timeout
        while not (self.states.seen[key] and self.states.seen[key][-1] in wanted):
            if time.monotonic() > deadline:
                raise AssertionError(f"{key} never {wanted} within {timeout:.0f} s: {self.states.seen[key]}")
            await asyncio.sleep(0.05)

    async def run(self, key: str, method: str, *args: ua.Variant, timeout: float = 120.0) -> str:
        """Start an action method, wait for its result (ResultCount), return LastOutcome."""
        before = await self.read(key, "Command.ResultCount")
        await self.good(key, method, *args)
        deadline = time.monotonic() + timeout
        while await self.read(key, "Command.ResultCount") == before:
            if time.monotonic() > deadline:
                raise AssertionError(f"{key}.{method}: no result within {timeout:.0f} s")
            await asyncio.sleep(0.05)
        assert await self.read(key, "Command.Busy") is False
        return str(await self.read(key, "Command.LastOutcome"))


def _in_order(seen: list[str], expected: list[str]) -> bool:
    """Whether ``expected`` occurs in ``seen`` as a subsequence (heartbeats may repeat a state)."""
    it = iter(seen)
    return all(any(state == want for state in it) for want in expected)


async def _cycle(plc: Plc, number: int, fault: bool) -> None:
    await plc.good(MEMS, "PlaceParts")
    goals = await plc.read(MEMS, "Command.GoalCount")
    outcome = await plc.run(MEMS, "RunProgram", text("orient_combined"), dbl(45.0), dbl(1e-4), dbl(0.0))
    assert outcome == "SETTLED", f"cycle {number}: {await plc.read(MEMS, 'Command.LastMessage')}"
    # The goal's variables: its count and action, its last feedback and its result (one part, settled).
    assert await plc.read(MEMS, "Command.GoalCount") == goals + 1
    assert await plc.read(MEMS, "Command.Action") == "RunProgram"
    assert await plc.read(MEMS, "Command.Feedback.Time") > 0
    assert len(await plc.read(MEMS, "Command.Result.Equilibrium")) == 1
    assert await plc.read(MEMS, "Command.Result.Settled") is True
    await plc.good(ARM, "PlacePart", i32(2), dbl(0.12))
    if fault:
        mark = len(plc.states.seen[ARM])
        assert "motor_fault" in await plc.good(
            ARM, "InjectFault", text("motor_fault"), dbl(0.0), boolean(False)
        )
        await plc.state(ARM, "Aborted")
        assert await plc.read(ARM, "Status.FaultCode") == 101
        code, message = await plc.call(ARM, "FeedPart", u32(40), dbl(60.0))
        assert code == ua.StatusCodes.BadInvalidState, message
        code, message = await plc.call(ARM, "Reset")  # PackML: no Reset out of Aborted
        assert code == ua.StatusCodes.BadInvalidState and "Clear" in message, message
        await plc.good(ARM, "Clear")
        await plc.state(ARM, "Stopped")
        assert await plc.read(ARM, "Status.FaultCode") == 0
        await plc.good(ARM, "Reset")
        await plc.state(ARM, "Idle")
        sequence = plc.states.since(ARM, mark)
        assert _in_order(sequence, ["Aborted", "Clearing", "Stopped", "Resetting", "Idle"]), sequence
        assert await plc.read(ARM, "Status.ActiveFaults") == []
        await plc.good(ARM, "PlacePart", i32(2), dbl(0.12))  # the infeed again, after the stop
    outcome = await plc.run(ARM, "FeedPart", u32(40), dbl(60.0))
    assert outcome == "PRESENTED", f"cycle {number}: {await plc.read(ARM, 'Command.LastMessage')}"
    throws = await plc.read(ARM, "Command.Result.Throws")
    assert throws >= 1 and await plc.read(ARM, "Command.Feedback.Throws") == throws
    assert await plc.read(ARM, "Command.Result.SensorAtRest") is True
    assert await plc.run(FIXTURE, "FollowPath", dbls([]), dbls(TILT)) == "REACHED"
    assert await plc.run(FIXTURE, "FollowPath", dbls([]), dbls(HOME)) == "REACHED"
    assert await plc.read(FIXTURE, "Command.LastOutcomeCode") == 1
    assert 0 < await plc.read(FIXTURE, "Command.Feedback.Progress") <= 1
    assert await plc.read(FIXTURE, "Command.Result.FirstUnstableSample") == -1
    assert await plc.read(FIXTURE, "Command.Result.Tilt") == pytest.approx([0.0, 0.0], abs=1e-6)


def test_a_plc_brings_the_cell_up_runs_three_cycles_recovers_a_fault_and_brings_it_down(
    plc_cell: str,
) -> None:
    async def scenario() -> None:
        client = Client(plc_cell, timeout=30, watchdog_intervall=10.0)
        await client.connect()
        try:
            idx = await client.get_namespace_index(NAMESPACE_URI)
            states = States()
            # Queue every change: the transient states (Resetting, Clearing) last one call.
            subscription = await client.create_subscription(20, states)
            for key in DEVICES:
                node = client.get_node(ua.NodeId(f"{key}.Status.PackMLState", idx))
                states.keys[node.nodeid] = key
                await subscription.subscribe_data_change(node, queuesize=20)
            plc = Plc(client, idx, states)
            for key in DEVICES:  # the scene leaves them unconfigured: Reset brings each up
                await plc.state(key, "Unconfigured")
                assert "configure" in await plc.good(key, "Reset")
            for key in DEVICES:
                await plc.state(key, "Idle", "Execute")  # the array executes while its parts move
                assert _in_order(states.seen[key], ["Unconfigured", "Resetting"]), states.seen[key]
            code, message = await plc.call(MEMS, "LoadProgram", text("no_such_program"))
            assert code == ua.StatusCodes.BadInvalidArgument and "Program" in message, message
            await plc.good(MEMS, "LoadProgram", text("orient_combined"))
            for number in (1, 2, 3):
                await _cycle(plc, number, fault=number == 2)
            counters = dict(
                zip(
                    await plc.read(ARM, "Status.CounterNames"),
                    await plc.read(ARM, "Status.CounterValues"),
                    strict=True,
                )
            )
            assert counters["feeds_presented"] >= 3, counters
            for key in DEVICES:  # and down again, through the lifecycle
                await plc.good(key, "Unconfigure")
                await plc.state(key, "Unconfigured")
            await subscription.delete()
        finally:
            await client.disconnect()

    asyncio.run(scenario())
