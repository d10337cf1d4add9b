"""The OPC UA gateway against running devices, driven by an independent OPC UA client (asyncua's).

The three devices run as real processes under /gw, the gateway on a free loopback port; each test opens
its own client session. Waits are bounded polls of OPC UA values or subscriptions, never fixed sleeps.
"""

from __future__ import annotations

import asyncio
import math
import socket
import time
from pathlib import Path
from typing import Any, Awaitable, Callable

import pytest
import ros_harness
from asyncua import Client, ua
from asyncua.ua.uaerrors import BadNotWritable, BadUserAccessDenied, UaError

from feeder_cell.gateway import alarms, layout, units
from feeder_cell.gateway.config import PACKML_STATES, packml_state
from feeder_cell.gateway.users import hash_password
from feeder_msgs.msg import DeviceStatus

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
NS = "/gw"
ARM, MEMS, FIXTURE = f"{NS}/throwing_arm", f"{NS}/mems_field_array", f"{NS}/assembly_fixture"
KEYS = {"arm": "gw.throwing_arm", "mems": "gw.mems_field_array", "fixture": "gw.assembly_fixture"}
DEVICES = {
    "throwing_arm": {"part_file": str(ROOT / "examples/throwing/triangle.yaml"), "period": 0.2},
    "mems_field_array": {
        "fidelity": "ideal",
        "part_files": [str(ROOT / "examples/mems/plus.yaml")],
        "seed": 7,
        "time_step": 5.0e-4,
    },
    "assembly_fixture": {},
}
# The client's health probe times out after this long (asyncua's default, 1 s, is shorter than a reply
# of a starved server on a loaded 2-core host).
WATCHDOG_S = 10.0
RADIAL = "{steps: [{field: {type: radial, center: [0, 0], strength: 1.0}}]}"


def free_port() -> int:
    """A TCP port free on loopback now (never 4840, the OPC UA default another server may hold)."""
    while True:
        with socket.socket() as sock:
            sock.bind(("127.0.0.1", 0))
            port = sock.getsockname()[1]
        if port != 4840:
            return port


@pytest.fixture(scope="module")
def gateway(launch_module_node: Callable[..., Any]) -> str:
    """The three devices and a gateway exposing them; returns the endpoint URL."""
    for executable, parameters in DEVICES.items():
        launch_module_node(
            "feeder_sim", executable, parameters, namespace=NS, wait_topics=(f"{NS}/{executable}/status",)
        )
    url = f"opc.tcp://127.0.0.1:{free_port()}"
    launch_module_node(
        "feeder_cell",
        "opcua_gateway",
        {"endpoint": url, "devices": [ARM, MEMS, FIXTURE], "program_dir": str(ROOT / "examples/mems")},
    )
    asyncio.run(_wait_until_serving(url))
    return url


async def _wait_until_serving(url: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while True:
        client = Client(url, timeout=5, watchdog_intervall=WATCHDOG_S)
        try:
            await client.connect()
            await client.disconnect()
            return
        except (OSError, UaError, asyncio.TimeoutError):
            if time.monotonic() > deadline:
                raise AssertionError(f"no OPC UA server on {url} within {timeout:.0f} s") from None
            await asyncio.sleep(0.2)


class Session:
    """An asyncua client session with the gateway's namespace resolved."""

    def __init__(self, client: Client, idx: int) -> None:
        self.client, self.idx = client, idx

    def node(self, key: str, path: str) -> Any:
        return self.client.get_node(ua.NodeId(layout.variable_id(key, path), self.idx))

    async def read(self, key: str, path: str) -> Any:
        return await self.node(key, path).read_value()

    async def wait_for(
        self, key: str, path: str, accept: Callable[[Any], bool], timeout: float = 20.0
    ) -> Any:
        """Poll a variable until ``accept`` takes its value; fail naming the last one."""
        deadline = time.monotonic() + timeout
        while True:
            dv = await self.node(key, path).read_data_value(raise_on_bad_status=False)
            value = dv.Value.Value if dv.Value is not None else None
            if dv.StatusCode.is_good() and accept(value):
                return value
            if time.monotonic() > deadline:
                raise AssertionError(f"{key}.{path} never accepted within {timeout:.0f} s; last {value!r}")
            await asyncio.sleep(0.05)

    async def call(self, key: str, method: str, *args: ua.Variant) -> ua.CallMethodResult:
        """Call a device method and return the whole CallMethodResult (Bad codes included)."""
        request = ua.CallMethodRequest()
        request.ObjectId = ua.NodeId(key, self.idx)
        request.MethodId = ua.NodeId(layout.method_id(key, method), self.idx)
        request.InputArguments = list(args)
        return (await self.client.uaclient.call([request]))[0]

    async def good(self, key: str, method: str, *args: ua.Variant) -> str:
        result = await self.call(key, method, *args)
        assert result.StatusCode.is_good(), (method, result)
        return result.OutputArguments[0].Value

    async def run(self, key: str, method: str, *args: ua.Variant, timeout: float = 60.0) -> str:
        """Start an action method, wait until its result is in, return LastOutcome."""
        before = await self.read(key, "Command.ResultCount")
        await self.good(key, method, *args)
        await self.wait_for(key, "Command.ResultCount", lambda n: n > before, timeout)
        assert await self.read(key, "Command.Busy") is False
        return await self.read(key, "Command.LastOutcome")


def session(url: str, scenario: Callable[[Session], Awaitable[None]], **login: str) -> None:
    """Run ``scenario`` in a fresh client session (anonymous unless user/password are given)."""

    async def main() -> None:
        client = Client(url, timeout=30, watchdog_intervall=WATCHDOG_S)
        if login:
            client.set_user(login["user"])
            client.set_password(login["password"])
        await client.connect()
        try:
            await scenario(Session(client, await client.get_namespace_index(layout.NAMESPACE_URI)))
        finally:
            await client.disconnect()

    asyncio.run(main())


def u32(value: int) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.UInt32)


def i32(value: int) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Int32)


def boolean(value: bool) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Boolean)


def dbl(value: float) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.Double)


def dbls(values: list[float]) -> ua.Variant:
    return ua.Variant(values, ua.VariantType.Double, is_array=True)


def text(value: str) -> ua.Variant:
    return ua.Variant(value, ua.VariantType.String)


async def idle(s: Session, key: str) -> None:
    await s.wait_for(key, "Status.PackMLState", lambda v: v == "Idle")


async def ready(s: Session, key: str) -> None:
    await s.wait_for(key, "Status.Ready", lambda v: v is True)


# --- the address space ---------------------------------------------------------------------------------


def test_address_space_has_one_object_per_device_with_its_variables_and_methods(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        folder = s.client.get_node(ua.NodeId(layout.DEVICES_FOLDER, s.idx))
        assert (await folder.read_browse_name()).Name == "Devices"
        cell = s.client.get_node(ua.NodeId(layout.CELL, s.idx))
        assert folder.nodeid in [c.nodeid for c in await cell.get_children()]
        assert (
            await s.client.nodes.objects.get_child([f"{s.idx}:Cell", f"{s.idx}:Devices"])
        ).nodeid == folder.nodeid
        devices = {(await c.read_browse_name()).Name: c for c in await folder.get_children()}
        assert sorted(devices) == sorted(KEYS.values())
        for key, kind in zip(
            KEYS.values(), ("throwing_arm", "mems_field_array", "assembly_fixture"), strict=True
        ):
            for spec in layout.variables(kind):
                node = s.node(key, spec.path)
                assert (await node.read_browse_name()).Name == spec.path.rsplit(".", 1)[-1]
                assert await node.read_node_class() == ua.NodeClass.Variable
            methods = await devices[key].get_methods()
            names = [(await m.read_browse_name()).Name for m in methods]
            assert sorted(names) == sorted(m.name for m in layout.methods(kind))
            assert await s.read(key, "Kind") == kind
            # One read of the status variables: online, ready, and the PackML state the mapping gives
            # (the MEMS array is RUNNING, Execute, while its parts still move; the others are IDLE).
            paths = (
                "Status.Online",
                "Status.Ready",
                "Status.State",
                "Status.StateName",
                "Status.PackMLState",
                "Status.PackMLStateCode",
            )
            deadline = time.monotonic() + 30
            while True:
                online, ready_, state, state_name, packml, code = await s.client.read_values(
                    [s.node(key, p) for p in paths]
                )
                if online and ready_:
                    break
                assert time.monotonic() < deadline, (key, online, ready_, state_name)
                await asyncio.sleep(0.1)
            assert state_name in ("IDLE", "RUNNING")
            assert (packml, code) == packml_state(state)
        # Per kind: the arm's sensor bit, the fixture's angles and margin, the MEMS parts' orientations.
        assert isinstance(
            await s.wait_for(KEYS["arm"], "Signals.Sensor", lambda v: isinstance(v, bool)), bool
        )
        margin = await s.wait_for(KEYS["fixture"], "Signals.StabilityMargin", lambda v: v is not None)
        assert math.isfinite(margin) and margin > 0
        assert await s.read(KEYS["fixture"], "Signals.TiltX") == pytest.approx(0.0, abs=1e-6)
        gravity = await s.read(KEYS["fixture"], "Signals.Gravity")
        assert len(gravity) == 3 and math.hypot(*gravity) == pytest.approx(1.0)
        orientations = await s.wait_for(KEYS["mems"], "Signals.PartOrientations", lambda v: len(v or []) == 1)
        assert 0.0 <= orientations[0] < 2 * math.pi
        assert len(await s.read(KEYS["mems"], "Signals.PartNames")) == 1
        # Values carry the DDS sample's stamp as SourceTimestamp (the device's clock, here the wall's).
        dv = await s.node(KEYS["arm"], "Status.State").read_data_value()
        assert abs(dv.SourceTimestamp.timestamp() - time.time()) < 600

    session(gateway, scenario)


def test_a_stop_over_ros_shows_as_a_data_change_and_the_reset_method_clears_it(
    gateway: str, ros_client: Any, listen: Callable[..., Any]
) -> None:
    statuses = listen(DeviceStatus, f"{ARM}/status", latched=True)

    async def scenario(s: Session) -> None:
        await idle(s, KEYS["arm"])
        changes: asyncio.Queue[tuple[Any, float, Any]] = asyncio.Queue()

        class Handler:
            def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
                changes.put_nowait((value, time.monotonic(), data.monitored_item.Value.SourceTimestamp))

        subscription = await s.client.create_subscription(20, Handler())
        # A queue: the transient Resetting and the Idle after it may fall into one publishing interval.
        await subscription.subscribe_data_change(s.node(KEYS["arm"], "Status.PackMLState"), queuesize=10)
        assert (await asyncio.wait_for(changes.get(), 10))[0] == "Idle"  # the initial value
        started, mark = time.monotonic(), statuses.count()
        response = await asyncio.to_thread(ros_harness.trigger, ros_client, ARM, "stop")
        assert response.success, response.message
        value, at, source = await asyncio.wait_for(changes.get(), 5)
        assert value == "Stopped" and at - started < 5
        assert await s.read(KEYS["arm"], "Status.StateName") == "STOPPED"
        # The value carries the stamp of the DDS sample that changed it (OPC UA keeps 100 ns): the first
        # STOPPED status since the stop, not the latest (ci34: a second STOPPED status 3.7 ms later).
        stopped = await asyncio.to_thread(
            statuses.wait, lambda m: m.state == DeviceStatus.STOPPED, 10, False, mark
        )
        assert abs(source.timestamp() * 1e9 - ros_harness.stamp_ns(stopped)) < 1e3
        message = await s.good(KEYS["arm"], "Reset")
        assert "IDLE" in message
        # PackML's way out of Stopped: Resetting while the device resets, then Idle.
        assert [(await asyncio.wait_for(changes.get(), 5))[0] for _ in range(2)] == ["Resetting", "Idle"]
        await subscription.delete()

    try:
        session(gateway, scenario)
    finally:
        # The module's tests share this arm: one left stopped by a failure here failed the next 11 (ci34).
        ros_harness.trigger(ros_client, ARM, "reset")


# --- a fault, bad arguments, rejections -----------------------------------------------------------------


def test_a_motor_fault_shows_in_the_variables_refuses_commands_and_reset_clears_it(
    gateway: str, ros_client: Any
) -> None:
    async def scenario(s: Session) -> None:
        key = KEYS["arm"]
        await idle(s, key)
        response = await asyncio.to_thread(ros_harness.inject_fault, ros_client, ARM, "motor_fault")
        assert response.ok, response.error
        await s.wait_for(key, "Status.FaultCode", lambda v: v == 101)
        assert await s.read(key, "Status.PackMLState") == "Aborted"
        assert await s.read(key, "Status.PackMLStateCode") == 9
        assert await s.read(key, "Status.Ready") is False
        assert "motor_fault" in await s.read(key, "Status.FaultText")
        assert "motor_fault" in await s.read(key, "Status.ActiveFaults")
        result = await s.call(key, "FeedPart", u32(3), dbl(5.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState
        assert "FAULT" in result.OutputArguments[0].Value and "Clear" in result.OutputArguments[0].Value
        assert await s.read(key, "Command.LastStatus") == "BadInvalidState"
        # PackML: Aborted -> Clearing -> Stopped -> Resetting -> Idle; no Reset straight out of Aborted.
        result = await s.call(key, "Reset")
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState, result
        assert "Aborted" in result.OutputArguments[0].Value and "Clear" in result.OutputArguments[0].Value
        await s.good(key, "Clear")
        await s.wait_for(key, "Status.PackMLState", lambda v: v == "Stopped")
        assert await s.read(key, "Status.FaultCode") == 0
        await s.good(key, "Reset")
        await idle(s, key)
        assert await s.read(key, "Status.ActiveFaults") == []

    session(gateway, scenario)


def _diagnostic(result: ua.CallMethodResult, index: int) -> str:
    return result.InputArgumentDiagnosticInfos[index].AdditionalInfo or ""


def test_bad_arguments_return_bad_codes_naming_the_argument_and_the_gateway_keeps_serving(
    gateway: str,
) -> None:
    async def scenario(s: Session) -> None:
        arm, mems, fixture = KEYS["arm"], KEYS["mems"], KEYS["fixture"]
        for key in KEYS.values():
            await ready(s, key)
        result = await s.call(arm, "FeedPart", u32(0), dbl(5.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument
        assert result.InputArgumentResults[0].value == ua.StatusCodes.BadInvalidArgument
        assert result.InputArgumentResults[1].is_good()
        assert "MaxThrows" in _diagnostic(result, 0)
        assert "MaxThrows" in await s.read(arm, "Command.LastMessage")
        result = await s.call(arm, "FeedPart", u32(2), dbl(math.nan))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument and "Timeout" in _diagnostic(
            result, 1
        )
        result = await s.call(arm, "FeedPart", u32(2))
        assert result.StatusCode.value == ua.StatusCodes.BadArgumentsMissing
        assert "Timeout" in result.OutputArguments[0].Value
        # A wrong type: Bad_InvalidArgument for the call, Bad_TypeMismatch for the argument (OPC 10000-4).
        result = await s.call(arm, "FeedPart", text("three"), dbl(1.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument and "MaxThrows" in _diagnostic(
            result, 0
        )
        assert result.InputArgumentResults[0].value == ua.StatusCodes.BadTypeMismatch
        result = await s.call(mems, "RunProgram", text("{steps: []}"), dbl(5.0), dbl(0.0), dbl(0.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument
        assert "Program.steps" in _diagnostic(result, 0)
        result = await s.call(mems, "RunProgram", text(RADIAL), dbl(-1.0), dbl(0.0), dbl(0.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument and "Timeout" in _diagnostic(
            result, 1
        )
        result = await s.call(fixture, "FollowPath", dbls([0.1, math.nan]), dbls([]))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument
        assert "TiltWaypoints[1]" in _diagnostic(result, 0)
        # A goal only the device can judge (a tilt beyond the joint limits): rejected, with its reason.
        result = await s.call(fixture, "FollowPath", dbls([3.0, 0.0]), dbls([]))
        assert result.StatusCode.is_bad(), result
        message = result.OutputArguments[0].Value
        assert "rejected by the device" in message and "tilt" in message, message
        assert await s.read(fixture, "Command.Busy") is False
        # Still serving: a good call works at once.
        assert "IDLE" in await s.good(arm, "Reset")
        assert await s.read(arm, "Command.LastStatus") == "Good"

    session(gateway, scenario)


# --- the status code table of docs/cell.md, one test per row ---------------------------------------------


def test_status_code_bad_invalid_state_feed_part_while_the_arm_is_busy_with_another_clients_goal(
    gateway: str, ros_client: Any
) -> None:
    from feeder_msgs.action import FeedPart
    from feeder_planner.node_kit.action_client import ActionClient

    # Another controller (a ROS client) keeps the arm busy: its sensor stuck false, a goal of many throws.
    other = ActionClient(ros_client, FeedPart, f"{ARM}/feed_part")
    assert other.wait_for_server(timeout_sec=30)

    async def scenario(s: Session) -> None:
        key = KEYS["arm"]
        await idle(s, key)
        response = await asyncio.to_thread(
            ros_harness.inject_fault, ros_client, ARM, "sensor_stuck", state=False
        )
        assert response.ok, response.error
        handle = None
        deadline = time.monotonic() + 30
        while handle is None or not handle.accepted:  # a reply may be lost to late discovery: repeat
            assert time.monotonic() < deadline, "the arm never accepted the other client's goal"
            future = other.send_goal_async(FeedPart.Goal(max_throws=10_000, timeout=0.0))
            handle = await asyncio.to_thread(_result_of, future, 5.0)
        try:
            await s.wait_for(key, "Status.Busy", lambda v: v is True)
            goals = await s.read(key, "Command.GoalCount")
            result = await s.call(key, "FeedPart", u32(3), dbl(5.0))
            assert result.StatusCode.value == ua.StatusCodes.BadInvalidState, result
            assert all(code.is_good() for code in result.InputArgumentResults), result
            assert await s.read(key, "Command.LastStatus") == "BadInvalidState"
            assert await s.read(key, "Command.GoalCount") == goals
            # The device refuses the infeed for the other client's goal (its action status says so).
            result = await s.call(key, "PlacePart", i32(2), dbl(0.12))
            assert result.StatusCode.value == ua.StatusCodes.BadInvalidState, result
        finally:
            await asyncio.to_thread(_result_of, handle.cancel_goal_async(), 10.0)
            message = await s.good(key, "ClearFault", ua.Variant("", ua.VariantType.String))  # every one
            assert "active faults: none" in message, message
        await idle(s, key)

    session(gateway, scenario)


def test_a_device_refusal_is_classified_by_the_devices_state_not_by_its_words(
    gateway: str, ros_client: Any
) -> None:
    """A service refused while a goal executes is BadInvalidState; refused for its contents, InvalidArgument.

    The arm's "place_part refused: a ~/feed_part goal is executing" names no state in words the gateway
    once matched, and read as BadInvalidArgument; the device's state (a goal executing) decides now.
    """

    async def scenario(s: Session) -> None:
        arm = KEYS["arm"]
        await idle(s, arm)
        # In Idle the device refuses an edge the part does not have: the request's contents.
        result = await s.call(arm, "PlacePart", i32(99), dbl(0.12))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument, result
        response = await asyncio.to_thread(
            ros_harness.inject_fault, ros_client, ARM, "sensor_stuck", state=False
        )
        assert response.ok, response.error
        await s.good(arm, "FeedPart", u32(10_000), dbl(0.0))
        try:
            await s.wait_for(arm, "Command.Busy", lambda v: v is True)
            result = await s.call(arm, "PlacePart", i32(2), dbl(0.12))
            assert result.StatusCode.value == ua.StatusCodes.BadInvalidState, result
            assert all(code.is_good() for code in result.InputArgumentResults), result
            assert "goal is executing" in result.OutputArguments[0].Value, result
            assert await s.read(arm, "Command.LastStatus") == "BadInvalidState"
            # A goal does not keep faults from being injected: an unknown one is still the argument's fault.
            result = await s.call(arm, "InjectFault", text("no_such_fault"), dbl(0.0), boolean(False))
            assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument, result
        finally:
            await s.good(arm, "Stop")
        await s.wait_for(arm, "Status.PackMLState", lambda v: v == "Stopped")
        # Stopped: the device refuses the infeed for its state, whatever the arguments.
        result = await s.call(arm, "PlacePart", i32(99), dbl(0.12))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState, result
        await s.good(arm, "Reset")
        await s.good(arm, "ClearFault", text(""))
        await idle(s, arm)

    session(gateway, scenario)


def _result_of(future: Any, timeout: float) -> Any:
    deadline = time.monotonic() + timeout
    while not future.done():
        if time.monotonic() > deadline:
            return None
        time.sleep(0.02)
    return future.result()


def test_status_code_bad_method_invalid_a_method_called_on_another_devices_object(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        arm, mems = KEYS["arm"], KEYS["mems"]
        await ready(s, arm)
        goals = await s.read(arm, "Command.GoalCount")
        request = ua.CallMethodRequest()
        request.ObjectId = ua.NodeId(mems, s.idx)  # the MEMS array's object, the arm's FeedPart
        request.MethodId = ua.NodeId(layout.method_id(arm, "FeedPart"), s.idx)
        request.InputArguments = [u32(1), dbl(1.0)]
        (result,) = await s.client.uaclient.call([request])
        assert result.StatusCode.value == ua.StatusCodes.BadMethodInvalid, result
        assert mems in result.OutputArguments[0].Value and arm in result.OutputArguments[0].Value
        assert await s.read(arm, "Command.GoalCount") == goals  # nothing ran
        # Stop and Reset of one device, called on another: refused alike.
        request.MethodId = ua.NodeId(layout.method_id(arm, "Reset"), s.idx)
        request.InputArguments = []
        (result,) = await s.client.uaclient.call([request])
        assert result.StatusCode.value == ua.StatusCodes.BadMethodInvalid, result

    session(gateway, scenario)


def test_status_code_bad_not_writable_writing_a_read_only_variable(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        for key, path, variant in (
            (KEYS["arm"], "Command.Busy", ua.Variant(True, ua.VariantType.Boolean)),
            (KEYS["arm"], "Status.Counters.throws", ua.Variant(0, ua.VariantType.UInt64)),
            (KEYS["fixture"], "Signals.TiltX", ua.Variant(0.5, ua.VariantType.Double)),
        ):
            with pytest.raises(BadNotWritable):
                await s.node(key, path).write_value(ua.DataValue(variant))
        with pytest.raises(BadNotWritable):  # another attribute than Value: its WriteMask is 0
            await s.node(KEYS["arm"], "Command.Busy").write_attribute(
                ua.AttributeIds.DisplayName, ua.DataValue(ua.Variant(ua.LocalizedText("Idle")))
            )
        assert await s.read(KEYS["arm"], "Command.Busy") is False

    session(gateway, scenario)


def test_status_code_bad_type_mismatch_an_argument_of_another_type_in_every_method(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        arm, mems, fixture = KEYS["arm"], KEYS["mems"], KEYS["fixture"]
        for key in KEYS.values():
            await ready(s, key)
        goals = {key: await s.read(key, "Command.GoalCount") for key in KEYS.values()}
        int32, float32 = ua.VariantType.Int32, ua.VariantType.Float
        for key, method, args, index in (
            (arm, "FeedPart", [ua.Variant(3, int32), dbl(5.0)], 0),  # Int32 for the UInt32 MaxThrows
            (arm, "FeedPart", [u32(3), ua.Variant(5, int32)], 1),  # Int32 for the Double Timeout
            (mems, "RunProgram", [text(RADIAL), ua.Variant(5.0, float32), dbl(0.0), dbl(0.0)], 1),
            (mems, "RunProgram", [u32(1), dbl(5.0), dbl(0.0), dbl(0.0)], 0),
            (fixture, "FollowPath", [ua.Variant([0, 0], int32, is_array=True), dbls([])], 0),
            (fixture, "FollowPath", [dbl(0.1), dbls([])], 0),  # a scalar for an array
        ):
            result = await s.call(key, method, *args)
            assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument, (method, args, result)
            codes = [c.value for c in result.InputArgumentResults]
            assert codes[index] == ua.StatusCodes.BadTypeMismatch, (method, args, result)
            assert all(c == ua.StatusCodes.Good for i, c in enumerate(codes) if i != index), result
            assert "expected" in _diagnostic(result, index)
        for key in KEYS.values():
            assert await s.read(key, "Command.GoalCount") == goals[key]

    session(gateway, scenario)


# --- PackML: the enumeration, warnings apart from faults ----------------------------------------------


def test_the_packml_state_code_is_an_enumeration_with_enum_values(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        node = s.node(KEYS["arm"], "Status.PackMLStateCode")
        dtype = s.client.get_node(await node.read_data_type())
        assert (await dtype.read_browse_name()).Name == layout.PACKML_STATE_TYPE
        supertype = await dtype.get_parent()  # HasSubtype from Enumeration
        assert supertype.nodeid == ua.NodeId(ua.ObjectIds.Enumeration)
        entries = await (await dtype.get_child("0:EnumValues")).read_value()
        names = {int(e.Value): e.DisplayName.Text for e in entries}
        assert names == {number: name for number, name, _ in PACKML_STATES}
        definition = await dtype.read_data_type_definition()
        assert {int(f.Value): f.Name for f in definition.Fields} == names
        # The value and the name agree, through the enumeration.
        for key in KEYS.values():
            await ready(s, key)
            code, name = await s.client.read_values(
                [s.node(key, "Status.PackMLStateCode"), s.node(key, "Status.PackMLState")]
            )
            assert names[code] == name

    session(gateway, scenario)


async def _enumeration(s: Session, key: str, path: str) -> tuple[str, dict[int, str]]:
    """Return the name of a variable's enumeration DataType and its EnumValues (number -> name)."""
    node = s.node(key, path)
    assert await node.read_data_type_as_variant_type() == ua.VariantType.Int32
    dtype = s.client.get_node(await node.read_data_type())
    assert (await dtype.get_parent()).nodeid == ua.NodeId(ua.ObjectIds.Enumeration)
    entries = await (await dtype.get_child("0:EnumValues")).read_value()
    names = {int(e.Value): e.DisplayName.Text for e in entries}
    definition = await dtype.read_data_type_definition()
    assert {int(f.Value): f.Name for f in definition.Fields} == names
    return (await dtype.read_browse_name()).Name, names


def test_the_state_and_the_outcome_codes_are_enumerations_too(gateway: str) -> None:
    """Status.State and Command.LastOutcomeCode say their meanings the way PackMLStateCode does."""

    async def scenario(s: Session) -> None:
        for key, (action, outcomes) in zip(
            KEYS.values(),
            (
                ("FeedPart", {1: "PRESENTED", 2: "MAX_THROWS", 3: "TIMEOUT", 4: "FAULT", 5: "CANCELED"}),
                ("RunProgram", {1: "SETTLED", 2: "TIMEOUT", 3: "FAULT", 4: "CANCELED"}),
                ("FollowPath", {1: "REACHED", 2: "REFUSED", 3: "STALLED", 4: "CANCELED", 5: "FAULT"}),
            ),
            strict=True,
        ):
            name, states = await _enumeration(s, key, "Status.State")
            assert name == "DeviceStateEnumeration"
            assert states == {
                0: "UNCONFIGURED",
                1: "IDLE",
                2: "RUNNING",
                3: "PAUSED",
                4: "FAULT",
                5: "STOPPED",
            }
            await ready(s, key)
            state, state_name = await s.client.read_values(
                [s.node(key, "Status.State"), s.node(key, "Status.StateName")]
            )
            assert states[state] == state_name
            name, codes = await _enumeration(s, key, "Command.LastOutcomeCode")
            assert name == f"{action}OutcomeEnumeration"
            assert codes == {0: "NONE", **outcomes}, codes

    session(gateway, scenario)


def test_a_non_stopping_fault_is_a_warning_not_a_fault(gateway: str, ros_client: Any) -> None:
    async def scenario(s: Session) -> None:
        key = KEYS["fixture"]
        await idle(s, key)
        response = await asyncio.to_thread(
            ros_harness.inject_fault, ros_client, FIXTURE, "rate_limit", indices=[1], value=0.25
        )
        assert response.ok, response.error
        try:
            assert await s.wait_for(key, "Status.WarningCode", lambda v: v == 302) == 302
            assert "rate_limit" in await s.read(key, "Status.WarningText")
            assert await s.read(key, "Status.FaultCode") == 0
            assert await s.read(key, "Status.FaultText") == ""
            assert await s.read(key, "Status.PackMLState") == "Idle"
        finally:
            await s.good(key, "Reset")
        await s.wait_for(key, "Status.WarningCode", lambda v: v == 0)
        assert await s.read(key, "Status.ActiveFaults") == []

    session(gateway, scenario)


# --- alarms: a fault and a warning as OPC UA conditions ------------------------------------------------


class _Events:
    """An event subscription's notifications with their wall-clock arrival time."""

    def __init__(self) -> None:
        self.queue: asyncio.Queue[tuple[Any, float]] = asyncio.Queue()

    def event_notification(self, event: Any) -> None:
        self.queue.put_nowait((event, time.time()))

    async def next(
        self, source: ua.NodeId, name: str, accept: Callable[[Any], bool], timeout: float = 10.0
    ) -> tuple[Any, float]:
        """The next event of ``source``'s condition ``name`` that ``accept`` takes (others are skipped)."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no {name} event accepted within {timeout:.0f} s")
            event, at = await asyncio.wait_for(self.queue.get(), left)
            if event.SourceNode == source and event.ConditionName == name and accept(event):
                return event, at


def _active(event: Any) -> bool:
    return bool(getattr(event, "ActiveState/Id"))


async def _acknowledge(s: Session, event: Any, comment: str) -> ua.CallMethodResult:
    request = ua.CallMethodRequest()
    request.ObjectId = event.NodeId  # the ConditionId
    request.MethodId = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
    request.InputArguments = [
        ua.Variant(event.EventId, ua.VariantType.ByteString),
        ua.Variant(ua.LocalizedText(comment), ua.VariantType.LocalizedText),
    ]
    return (await s.client.uaclient.call([request]))[0]


def test_a_device_fault_raises_an_alarm_a_warning_a_lower_one_and_both_clear(
    gateway: str, ros_client: Any, listen: Callable[..., Any]
) -> None:
    statuses = listen(DeviceStatus, f"{ARM}/status", latched=True)

    async def scenario(s: Session) -> None:
        arm, fixture = KEYS["arm"], KEYS["fixture"]
        await idle(s, arm)
        await idle(s, fixture)
        events = _Events()
        subscription = await s.client.create_subscription(0, events)
        await subscription.subscribe_events(s.client.nodes.server, ua.ObjectIds.AlarmConditionType)
        response = await asyncio.to_thread(ros_harness.inject_fault, ros_client, ARM, "motor_fault")
        assert response.ok, response.error
        arm_id, fixture_id = ua.NodeId(arm, s.idx), ua.NodeId(fixture, s.idx)
        raised, at = await events.next(arm_id, "Fault", _active)
        assert raised.Severity == alarms.FAULT_SEVERITY
        assert raised.SourceName == arm
        assert raised.NodeId == ua.NodeId(alarms.condition_id(arm, "Fault"), s.idx)
        assert "101" in raised.Message.Text and "motor_fault" in raised.Message.Text
        assert getattr(raised, "AckedState/Id") is False and raised.Retain is True
        # The event's Time is the gateway's wall clock when it emitted it, after the DeviceStatus's stamp
        # (here a wall clock too); the stamp itself is Status.FaultCode's SourceTimestamp.
        faulted = await asyncio.to_thread(statuses.wait, lambda m: m.state == DeviceStatus.FAULT, 10, True)
        assert 0 <= raised.Time.timestamp() - ros_harness.stamp_ns(faulted) / 1e9 < 2.0
        code = await s.node(arm, "Status.FaultCode").read_data_value()
        assert abs(code.SourceTimestamp.timestamp() * 1e9 - ros_harness.stamp_ns(faulted)) < 1e3
        latency = at - ros_harness.stamp_ns(faulted) / 1e9
        print(f"fault alarm: {latency * 1e3:.1f} ms from the device's status stamp to the client")
        assert latency < 2.0  # loosely: the 100 ms target is bench/bench_gateway.py's

        assert (await _acknowledge(s, raised, "seen by the PLC")).StatusCode.is_good()
        acked, _ = await events.next(arm_id, "Fault", lambda e: bool(getattr(e, "AckedState/Id")))
        assert _active(acked) and acked.Retain is True
        await s.good(arm, "Clear")
        cleared, _ = await events.next(arm_id, "Fault", lambda e: not _active(e))
        assert cleared.SourceNode == ua.NodeId(arm, s.idx)
        assert cleared.Retain is False  # acknowledged and inactive
        await s.wait_for(arm, "Status.PackMLState", lambda v: v == "Stopped")
        await s.good(arm, "Reset")

        response = await asyncio.to_thread(
            ros_harness.inject_fault, ros_client, FIXTURE, "rate_limit", indices=[1], value=0.25
        )
        assert response.ok, response.error
        try:
            warning, _ = await events.next(fixture_id, "Warning", _active)
            assert warning.SourceNode == ua.NodeId(fixture, s.idx)
            assert warning.Severity == alarms.WARNING_SEVERITY < alarms.FAULT_SEVERITY
            assert "302" in warning.Message.Text
        finally:
            await s.good(fixture, "Reset")
        gone, _ = await events.next(fixture_id, "Warning", lambda e: not _active(e))
        assert gone.Retain is True  # not acknowledged: retained until it is
        assert (await _acknowledge(s, gone, "")).StatusCode.is_good()
        final, _ = await events.next(fixture_id, "Warning", lambda e: bool(getattr(e, "AckedState/Id")))
        assert final.Retain is False
        await subscription.delete()

    session(gateway, scenario)


# --- standard types: units, counters, build info; Busy with the state ---------------------------------


def test_engineering_units_uint32_counters_and_build_info(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        build = await s.client.get_node(ua.ObjectIds.Server_ServerStatus_BuildInfo).read_value()
        assert build.ProductName == "feeder opcua_gateway" and build.SoftwareVersion == "0.1.0", build
        assert "FreeOpcUa" not in f"{build.ProductName} {build.ManufacturerName}"
        for key, kind in zip(
            KEYS.values(), ("throwing_arm", "mems_field_array", "assembly_fixture"), strict=True
        ):
            analog = 0
            for spec in layout.variables(kind):
                # What Browse says of the variable (its parent's HasComponent reference carries the
                # TypeDefinition a client takes) must be the node's own HasTypeDefinition.
                node = s.node(key, spec.path)
                browsed = [
                    r
                    for r in await (await node.get_parent()).get_references(ua.ObjectIds.HasComponent)
                    if r.NodeId == node.nodeid
                ]
                assert len(browsed) == 1, spec.path
                own = await node.read_type_definition()
                assert browsed[0].TypeDefinition == own, (spec.path, browsed[0].TypeDefinition, own)
                if not spec.unit:
                    continue
                analog += 1
                assert own.Identifier == ua.ObjectIds.BaseAnalogType
                info = await (await node.get_child("0:EngineeringUnits")).read_value()
                assert info.NamespaceUri == units.UNECE_NAMESPACE
                assert info.UnitId == units.unit_id(spec.unit), spec.path
                assert info.DisplayName.Text == units.UNITS[spec.unit].symbol
            assert analog > 0, kind
        arm = KEYS["arm"]
        await s.wait_for(arm, "Status.Counters32.throws", lambda v: v is not None)
        wide, narrow, values, values32 = await s.client.read_values(
            [
                s.node(arm, "Status.Counters.throws"),
                s.node(arm, "Status.Counters32.throws"),
                s.node(arm, "Status.CounterValues"),
                s.node(arm, "Status.CounterValues32"),
            ]
        )
        assert narrow == wide % 2**32 and values32 == [v % 2**32 for v in values]
        dv = await s.node(arm, "Status.Counters32.throws").read_data_value()
        assert dv.Value.VariantType == ua.VariantType.UInt32

    session(gateway, scenario)


def test_busy_turns_true_with_the_state_change_or_with_the_acceptance_and_last_outcome_is_cleared(
    gateway: str, ros_client: Any
) -> None:
    async def scenario(s: Session) -> None:
        key = KEYS["arm"]
        await idle(s, key)
        assert await s.run(key, "FeedPart", u32(1), dbl(0.0)) in ("PRESENTED", "MAX_THROWS")
        response = await asyncio.to_thread(
            ros_harness.inject_fault, ros_client, ARM, "sensor_stuck", state=False
        )
        assert response.ok, response.error
        publishes: list[tuple[int, Any]] = []  # (sequence number, value) of every notification
        subscription = await s.client.create_subscription(20, _Ignore())
        original = subscription.publish_callback

        async def recording(result: ua.PublishResult) -> None:
            sequence = result.NotificationMessage.SequenceNumber
            for data in result.NotificationMessage.NotificationData or []:
                if isinstance(data, ua.DataChangeNotification):
                    publishes.extend((sequence, item.Value.Value.Value) for item in data.MonitoredItems)
            await original(result)

        # The client's publish loop calls the callback registered for the subscription: record each
        # publish's notifications with its sequence number, then hand them on.
        s.client.uaclient._subscription_callbacks[subscription.subscription_id] = recording
        await subscription.subscribe_data_change(
            [s.node(key, p) for p in ("Command.Busy", "Status.PackMLState", "Command.LastOutcome")]
        )
        try:
            await _until(lambda: "Idle" in [v for _, v in publishes], 10, "the initial values")
            await s.good(key, "FeedPart", u32(10_000), dbl(0.0))
            await _until(lambda: any(v is True for _, v in publishes), 10, "Command.Busy true")
            busy_in = next(seq for seq, v in publishes if v is True)
            together = [v for seq, v in publishes if seq == busy_in]
            execute_in = next(seq for seq, v in publishes if v == "Execute")
            if execute_in != busy_in:
                # docs/cell.md: Busy turns true with the status that shows the goal executing, or at once
                # (with the acceptance's clearing of LastOutcome) when the device showed it before the
                # gateway had the acceptance: the goal's answer and the status topic are two DDS writers
                # in no order (ci38: Execute in publish 2, the acceptance and Busy in publish 3).
                assert execute_in < busy_in and "" in together, publishes
            assert "" in together or await s.read(key, "Command.LastOutcome") == "", publishes
            assert await s.read(key, "Command.LastOutcome") == ""
            assert await s.read(key, "Command.LastOutcomeCode") == 0
        finally:
            await subscription.delete()
            await s.good(key, "Stop")
            await s.wait_for(key, "Command.Busy", lambda v: v is False)
            await s.good(key, "Reset")
        assert await s.read(key, "Command.LastOutcome") == "CANCELED"
        await idle(s, key)

    session(gateway, scenario)


class _Ignore:
    def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
        pass


async def _until(condition: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"{what}: not within {timeout:g} s"
        await asyncio.sleep(0.02)


# --- a whole cycle through OPC UA ------------------------------------------------------------------------


def test_stop_ends_a_long_goal_and_the_device_is_commandable_after_reset(
    gateway: str, ros_client: Any
) -> None:
    async def scenario(s: Session) -> None:
        arm = KEYS["arm"]
        await idle(s, arm)
        results = await s.read(arm, "Command.ResultCount")
        # The triangle is often presented within a few throws: a sensor stuck false keeps the goal
        # throwing until Stop ends it (Reset clears the fault).
        response = await asyncio.to_thread(
            ros_harness.inject_fault, ros_client, ARM, "sensor_stuck", state=False
        )
        assert response.ok, response.error
        await s.good(arm, "FeedPart", u32(10_000), dbl(0.0))
        # The previous test's goal left Throws above 0: acceptance clears it, so this is the new goal's.
        assert await s.read(arm, "Command.Feedback.Throws") == 0
        await s.wait_for(arm, "Command.Feedback.Throws", lambda n: n >= 1)
        await s.wait_for(arm, "Command.Busy", lambda v: v is True)
        assert "Stop" in await s.good(arm, "Stop")
        await s.wait_for(arm, "Command.ResultCount", lambda n: n == results + 1)
        assert await s.read(arm, "Command.Busy") is False
        assert await s.read(arm, "Command.LastOutcome") == "CANCELED"
        assert "stop" in (await s.read(arm, "Command.LastMessage")).lower()
        await s.wait_for(arm, "Status.PackMLState", lambda v: v == "Stopped")
        await s.good(arm, "Reset")
        await idle(s, arm)
        assert await s.read(arm, "Status.ActiveFaults") == []
        assert await s.run(arm, "FeedPart", u32(1), dbl(0.0)) in ("PRESENTED", "MAX_THROWS")

    session(gateway, scenario)


def test_an_unconfigured_device_is_not_stopped_and_one_that_stops_reporting_goes_offline(
    launch_node: Callable[..., Any], ros_client: Any
) -> None:
    namespace = "/gw_offline"
    arm = launch_node(
        "feeder_sim",
        "throwing_arm",
        DEVICES["throwing_arm"],
        namespace=namespace,
        wait_topics=(f"{namespace}/throwing_arm/status",),
        lifecycle="unconfigured",
    )
    url = f"opc.tcp://127.0.0.1:{free_port()}"
    launch_node("feeder_cell", "opcua_gateway", {"endpoint": url, "devices": [f"{namespace}/throwing_arm"]})
    asyncio.run(_wait_until_serving(url))
    key = "gw_offline.throwing_arm"

    async def scenario(s: Session) -> None:
        await s.wait_for(key, "Status.Online", lambda v: v is True)
        # Unconfigured is its own PackML value (the gateway's 100), not Stopped: Reset would not help.
        assert await s.wait_for(key, "Status.PackMLState", lambda v: v == "Unconfigured") == "Unconfigured"
        assert await s.read(key, "Status.PackMLStateCode") == 100
        assert await s.read(key, "Status.StateName") == "UNCONFIGURED"
        result = await s.call(key, "FeedPart", u32(1), dbl(0.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState
        assert "configure" in result.OutputArguments[0].Value
        assert await asyncio.to_thread(ros_harness.bring_to, ros_client, arm, "active") == "active"
        await idle(s, key)
        assert await s.read(key, "Status.PackMLStateCode") == 4
        await asyncio.to_thread(arm.stop)
        await s.wait_for(key, "Status.Online", lambda v: v is False, timeout=15)
        assert await s.read(key, "Status.PackMLState") == "Undefined"
        assert await s.read(key, "Status.PackMLStateCode") == 0
        result = await s.call(key, "FeedPart", u32(1), dbl(0.0))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState
        assert "reports no status" in result.OutputArguments[0].Value

    session(url, scenario)


# --- security -----------------------------------------------------------------------------------------------


def test_anonymous_on_a_non_loopback_endpoint_is_refused_at_start(ros_client: Any, tmp_path: Path) -> None:
    node = ros_harness.start_node(
        "feeder_cell", "opcua_gateway", {"endpoint": f"opc.tcp://0.0.0.0:{free_port()}"}, tmp_path
    )
    try:
        code = node.process.wait(timeout=30)
    finally:
        node.stop()
    log = node.output()
    assert code == 2, log
    assert "parameter allow_anonymous" in log and "allow_anonymous_remote" in log, log
    assert "Traceback" not in log


def test_a_bad_device_entry_or_a_busy_endpoint_fails_the_start_naming_the_parameter(tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        for parameters, words in (
            (
                {"endpoint": f"opc.tcp://127.0.0.1:{free_port()}", "devices": ["/cell/feeder_a"]},
                "parameter devices[0]",
            ),
            ({"endpoint": f"opc.tcp://127.0.0.1:{port}"}, "parameter endpoint: cannot listen"),
        ):
            node = ros_harness.start_node("feeder_cell", "opcua_gateway", parameters, tmp_path)
            try:
                code = node.process.wait(timeout=30)
            finally:
                node.stop()
            log = node.output()
            assert code == 2 and words in log and "Traceback" not in log, log


def test_user_and_password(launch_node: Callable[..., Any], tmp_path: Path) -> None:
    users = tmp_path / "users.yaml"
    users.write_text(
        f'users:\n  plc: {{role: Operator, hash: "{hash_password("line-7", iterations=20_000)}"}}\n'
    )
    url = f"opc.tcp://127.0.0.1:{free_port()}"
    launch_node(
        "feeder_cell",
        "opcua_gateway",
        {"endpoint": url, "devices": [ARM], "users_file": str(users), "allow_anonymous": False},
        namespace="/gw_login",
    )

    async def connects(**login: str) -> bool:
        client = Client(url, timeout=30, watchdog_intervall=WATCHDOG_S)
        if login:
            client.set_user(login["user"])
            client.set_password(login["password"])
        try:
            await client.connect()
        except (BadUserAccessDenied, UaError) as error:
            assert "Bad" in type(error).__name__ or "denied" in str(error).lower() or str(error), error
            return False
        try:
            idx = await client.get_namespace_index(layout.NAMESPACE_URI)
            kind = await client.get_node(
                ua.NodeId(layout.variable_id("gw.throwing_arm", "Kind"), idx)
            ).read_value()
            assert kind == "throwing_arm"
            return True
        finally:
            await client.disconnect()

    async def main() -> None:
        deadline = time.monotonic() + 30
        while not await _try(connects(user="plc", password="line-7")):
            assert time.monotonic() < deadline, "the right password never got in"
            await asyncio.sleep(0.2)
        assert not await connects(user="plc", password="line-8")
        assert not await connects(user="someone", password="line-7")
        assert not await connects()  # anonymous, refused by allow_anonymous false
        assert await connects(user="plc", password="line-7")

    asyncio.run(main())


async def _try(attempt: Awaitable[bool]) -> bool:
    try:
        return await attempt
    except (OSError, asyncio.TimeoutError):
        return False  # not listening yet


def test_certificate_security_basic256sha256_sign_and_encrypt_with_trusted_clients(
    launch_node: Callable[..., Any], tmp_path: Path
) -> None:
    from asyncua.crypto.cert_gen import setup_self_signed_certificate
    from cryptography.x509.oid import ExtendedKeyUsageOID

    async def certificates() -> None:
        for who, uri, use in (
            ("server", layout.APPLICATION_URI, ExtendedKeyUsageOID.SERVER_AUTH),
            ("client", "urn:feeder:test:plc", ExtendedKeyUsageOID.CLIENT_AUTH),
            ("stranger", "urn:feeder:test:stranger", ExtendedKeyUsageOID.CLIENT_AUTH),
        ):
            await setup_self_signed_certificate(
                tmp_path / f"{who}_key.pem",
                tmp_path / f"{who}_cert.der",
                uri,
                "localhost",
                [use],
                {"commonName": who},
            )

    asyncio.run(certificates())
    trusted = tmp_path / "trusted"
    trusted.mkdir()
    (trusted / "client_cert.der").write_bytes((tmp_path / "client_cert.der").read_bytes())
    url = f"opc.tcp://127.0.0.1:{free_port()}"
    launch_node(
        "feeder_cell",
        "opcua_gateway",
        {
            "endpoint": url,
            "devices": [ARM],
            "security_policies": ["Basic256Sha256_SignAndEncrypt"],
            "certificate_file": str(tmp_path / "server_cert.der"),
            "private_key_file": str(tmp_path / "server_key.pem"),
            "trusted_certificates_dir": str(trusted),
        },
        namespace="/gw_cert",
    )

    async def main() -> None:
        await _wait_for_endpoints(url)
        plain = Client(url, timeout=30, watchdog_intervall=WATCHDOG_S)
        endpoints = await plain.connect_and_get_server_endpoints()
        assert {e.SecurityPolicyUri.rsplit("#", 1)[-1] for e in endpoints} == {"Basic256Sha256"}
        assert {e.SecurityMode for e in endpoints} == {ua.MessageSecurityMode.SignAndEncrypt}
        with pytest.raises((UaError, OSError, asyncio.TimeoutError)):
            await plain.connect()  # no security: no endpoint offers it
        stranger = Client(url, timeout=4, watchdog_intervall=WATCHDOG_S)
        stranger.application_uri = "urn:feeder:test:stranger"
        await stranger.set_security_string(
            f"Basic256Sha256,SignAndEncrypt,{tmp_path / 'stranger_cert.der'},{tmp_path / 'stranger_key.pem'}"
        )
        with pytest.raises((UaError, OSError, asyncio.TimeoutError)):
            await stranger.connect()  # a certificate the gateway does not trust
        secure = Client(url, timeout=30, watchdog_intervall=WATCHDOG_S)
        secure.application_uri = "urn:feeder:test:plc"
        await secure.set_security_string(
            f"Basic256Sha256,SignAndEncrypt,{tmp_path / 'client_cert.der'},{tmp_path / 'client_key.pem'}"
        )
        await secure.connect()
        try:
            idx = await secure.get_namespace_index(layout.NAMESPACE_URI)
            node = secure.get_node(ua.NodeId(layout.variable_id("gw.throwing_arm", "Kind"), idx))
            assert await node.read_value() == "throwing_arm"
        finally:
            await secure.disconnect()

    asyncio.run(main())


async def _wait_for_endpoints(url: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while True:
        try:
            await Client(url, timeout=5, watchdog_intervall=WATCHDOG_S).connect_and_get_server_endpoints()
            return
        except (OSError, UaError, asyncio.TimeoutError):
            if time.monotonic() > deadline:
                raise AssertionError(f"no OPC UA server on {url} within {timeout:.0f} s") from None
            await asyncio.sleep(0.2)


def test_abort_clear_reset_and_suspend_unsuspend_follow_packml(gateway: str) -> None:
    async def scenario(s: Session) -> None:
        fixture = KEYS["fixture"]
        await idle(s, fixture)
        result = await s.call(fixture, "Clear")  # Clear applies in Aborted only
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState
        assert "Aborted" in result.OutputArguments[0].Value
        await s.good(fixture, "Abort")
        await s.wait_for(fixture, "Status.PackMLState", lambda v: v == "Aborted")
        assert await s.read(fixture, "Status.FaultCode") == DeviceStatus.FAULT_ABORTED
        assert "abort" in (await s.read(fixture, "Status.FaultText")).lower()
        await s.good(fixture, "Clear")
        await s.wait_for(fixture, "Status.PackMLState", lambda v: v == "Stopped")
        await s.good(fixture, "Reset")
        await idle(s, fixture)
        await s.good(fixture, "Suspend")
        await s.wait_for(fixture, "Status.PackMLState", lambda v: v == "Suspended")
        result = await s.call(fixture, "FollowPath", dbls([0.1, 0.0]), dbls([]))
        assert result.StatusCode.value == ua.StatusCodes.BadInvalidState
        assert "Unsuspend" in result.OutputArguments[0].Value
        await s.good(fixture, "Unsuspend")
        await idle(s, fixture)

    session(gateway, scenario)


def _client_certificate(folder: Path, name: str, uri: str, days: tuple[float, float]) -> tuple[Path, Path]:
    """Make a client certificate for ``uri`` valid from ``days[0]`` to ``days[1]`` days from now."""
    import datetime as dt

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import rsa
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    now = dt.datetime.now(dt.timezone.utc)
    certificate = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now + dt.timedelta(days=days[0]))
        .not_valid_after(now + dt.timedelta(days=days[1]))
        .add_extension(x509.SubjectAlternativeName([x509.UniformResourceIdentifier(uri)]), critical=False)
        .add_extension(
            x509.KeyUsage(True, True, True, True, False, True, False, False, False), critical=False
        )
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
        .sign(key, hashes.SHA256())
    )
    cert_path, key_path = folder / f"{name}_cert.der", folder / f"{name}_key.pem"
    cert_path.write_bytes(certificate.public_bytes(serialization.Encoding.DER))
    key_path.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
        )
    )
    return cert_path, key_path


def test_without_a_trust_list_a_client_certificate_is_still_checked_for_itself(
    launch_node: Callable[..., Any], tmp_path: Path
) -> None:
    """No trusted_certificates_dir: any issuer opens a channel, not an expired or another client's one."""
    uri = "urn:feeder:test:plc"
    cases = {
        "good": (uri, (-1, 365), None),
        "expired": (uri, (-30, -1), "BadCertificateTimeInvalid"),
        "not_yet_valid": (uri, (1, 365), "BadCertificateTimeInvalid"),
        "foreign_uri": ("urn:feeder:test:someone-else", (-1, 365), "BadCertificateUriInvalid"),
    }
    made = {name: _client_certificate(tmp_path, name, u, days) for name, (u, days, _) in cases.items()}
    url = f"opc.tcp://127.0.0.1:{free_port()}"
    launch_node(
        "feeder_cell",
        "opcua_gateway",
        {
            "endpoint": url,
            "devices": [ARM],
            "security_policies": ["Basic256Sha256_SignAndEncrypt"],
            "pki_dir": str(tmp_path / "pki"),
        },
        namespace="/gw_selfcheck",
    )

    async def connect(name: str) -> str:
        cert, key = made[name]
        client = Client(url, timeout=10, watchdog_intervall=WATCHDOG_S)
        client.application_uri = uri
        await client.set_security_string(f"Basic256Sha256,SignAndEncrypt,{cert},{key}")
        try:
            await client.connect()
        except Exception as error:  # noqa: BLE001 - the refusal's name is what is judged
            return type(error).__name__ + " " + str(error)
        await client.disconnect()
        return "Good"

    async def main() -> None:
        await _wait_for_endpoints(url)
        for name, (_, _, refusal) in cases.items():
            said = await connect(name)
            if refusal is None:
                assert said == "Good", (name, said)
            else:
                assert refusal in said, (name, said)

    asyncio.run(main())


def test_the_gateways_own_diagnostics_entry_has_its_devices_its_start_and_its_logins(
    gateway: str, listen: Callable[..., Any]
) -> None:
    """The gateway's /diagnostics entry: each device online, what the start-up wait found, login counts."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

    diagnostics = listen(DiagnosticArray, "/diagnostics")

    async def scenario(s: Session) -> None:
        assert await s.read(KEYS["arm"], "Kind") == "throwing_arm"  # this session's login is counted

    session(gateway, scenario)

    def ours(msg: Any) -> bool:
        return any(status.name.endswith("opcua_gateway") for status in msg.status)

    msg = diagnostics.wait(ours, timeout=10)
    entry = next(status for status in msg.status if status.name.endswith("opcua_gateway"))
    values = {kv.key: kv.value for kv in entry.values}
    assert entry.level == DiagnosticStatus.OK and entry.message == "every device online", entry
    assert all(values[f"{device} online"] == "true" for device in (ARM, MEMS, FIXTURE)), values
    assert values["startup"].startswith("every device heard and its services discovered in "), values
    assert int(values["logins_accepted"]) >= 1 and int(values["logins_refused"]) == 0, values
