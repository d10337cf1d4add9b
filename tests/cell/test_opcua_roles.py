"""Roles over OPC UA without ROS: a GatewayServer in this process, asyncua clients logged in as each role.

An Observer browses, reads and subscribes; an Operator also calls the devices' methods and acknowledges
alarms; an Engineer also loads and runs programs (docs/cell.md: Roles). A call out of the session's role
is Bad_UserAccessDenied, logged, and never reaches the device; UserExecutable, UserAccessLevel and
UserRolePermissions show the session's rights, RolePermissions the node's.
"""

from __future__ import annotations

import asyncio
import logging
import socket
from pathlib import Path
from typing import Any

import pytest
from asyncua import Client, ua

from feeder_cell.gateway import alarms, layout
from feeder_cell.gateway.config import DeviceEntry, Endpoint, SecurityConfig
from feeder_cell.gateway.roles import Role
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Goal
from feeder_cell.gateway.users import hash_password, load_users
from feeder_planner.errors import InputError

ARM = DeviceEntry("throwing_arm", "/r/throwing_arm")
MEMS = DeviceEntry("mems_field_array", "/r/mems_field_array")
PASSWORD = "line-7"
USERS = {"viewer": "Observer", "operator": "Operator", "engineer": "Engineer"}
RADIAL = "{steps: [{field: {type: radial, center: [0, 0], strength: 1.0}}]}"
CALL = int(ua.PermissionType.Call)  # the bit itself


class _Recorder:
    """The device side: records what reached it, answers Good."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str]] = []

    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        self.calls.append((device.key, method))
        return "Good", f"{method}: done"


def _port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def _call(client: Client, idx: int, key: str, method: str, *args: ua.Variant) -> ua.CallMethodResult:
    request = ua.CallMethodRequest()
    request.ObjectId = ua.NodeId(key, idx)
    request.MethodId = ua.NodeId(layout.method_id(key, method), idx)
    request.InputArguments = list(args)
    return (await client.uaclient.call([request]))[0]


async def _attribute(client: Client, nodeid: ua.NodeId, attribute: int) -> ua.DataValue:
    item = ua.ReadValueId()
    item.NodeId, item.AttributeId = nodeid, attribute
    params = ua.ReadParameters()
    params.NodesToRead = [item]
    return (await client.uaclient.read(params))[0]


def _users_file(folder: Path) -> Path:
    path = folder / "users.yaml"
    lines = [
        f'  {name}: {{role: {role}, hash: "{hash_password(PASSWORD, iterations=1000)}"}}'
        for name, role in USERS.items()
    ]
    path.write_text("users:\n" + "\n".join(lines) + "\n")
    return path


class _Session:
    def __init__(self, client: Client, idx: int) -> None:
        self.client, self.idx = client, idx

    async def call(self, key: str, method: str, *args: ua.Variant) -> ua.CallMethodResult:
        return await _call(self.client, self.idx, key, method, *args)

    async def read(self, key: str, method: str, attribute: int) -> Any:
        value = await _attribute(self.client, ua.NodeId(layout.method_id(key, method), self.idx), attribute)
        assert value.StatusCode is None or value.StatusCode.is_good(), (method, attribute, value)
        return value.Value.Value if value.Value is not None else None


async def _acknowledge(s: _Session) -> ua.StatusCode:
    """Acknowledge the arm's raised Fault with the EventId its condition shows."""
    condition = s.client.get_node(ua.NodeId(alarms.condition_id(ARM.key, "Fault"), s.idx))
    event_id = await (await condition.get_child(ua.QualifiedName("EventId", 0))).read_value()
    request = ua.CallMethodRequest()
    request.ObjectId = condition.nodeid
    request.MethodId = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
    request.InputArguments = [
        ua.Variant(event_id, ua.VariantType.ByteString),
        ua.Variant(ua.LocalizedText("seen"), ua.VariantType.LocalizedText),
    ]
    return (await s.client.uaclient.call([request]))[0].StatusCode


async def _as(url: str, user: str | None, scenario: Any) -> None:
    client = Client(url, timeout=10)
    if user is not None:
        client.set_user(user)
        client.set_password(PASSWORD)
    await client.connect()
    try:
        await scenario(_Session(client, await client.get_namespace_index(layout.NAMESPACE_URI)))
    finally:
        await client.disconnect()


def test_each_role_calls_what_it_may_and_reads_its_own_rights(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    recorder = _Recorder()

    async def main() -> None:
        url = f"opc.tcp://127.0.0.1:{_port()}"
        security = SecurityConfig(("None",), "", "", True, "", anonymous_role=Role.Observer)
        users = load_users(str(_users_file(tmp_path)))
        endpoint = Endpoint(url, "127.0.0.1", int(url.rsplit(":", 1)[1]))
        gateway = GatewayServer(endpoint, security, users, (ARM, MEMS), recorder)
        await gateway.start()
        gateway.post_all(ARM.key, {"Status.FaultCode": 101, "Status.FaultText": "motor_fault injected"})
        try:

            async def viewer(s: _Session) -> None:
                for key, method in ((ARM.key, "Stop"), (ARM.key, "Reset"), (MEMS.key, "PlaceParts")):
                    result = await s.call(key, method)
                    assert result.StatusCode.value == ua.StatusCodes.BadUserAccessDenied, (method, result)
                    assert "viewer is Observer" in result.OutputArguments[0].Value
                assert await s.read(ARM.key, "Stop", ua.AttributeIds.UserExecutable) is False
                assert await s.read(ARM.key, "Stop", ua.AttributeIds.Executable) is True
                mine = await s.read(ARM.key, "Stop", ua.AttributeIds.UserRolePermissions)
                assert [(p.RoleId, p.Permissions & CALL) for p in mine] == [(Role.Observer.node_id, 0)]
                every = await s.read(ARM.key, "Stop", ua.AttributeIds.RolePermissions)
                called = {p.RoleId: bool(p.Permissions & CALL) for p in every}
                assert called == {r.node_id: r >= Role.Operator for r in Role}, called
                # A variable: readable by every role, writable by none.
                variable = ua.NodeId(layout.variable_id(ARM.key, "Status.Online"), s.idx)
                level = await _attribute(s.client, variable, ua.AttributeIds.UserAccessLevel)
                assert level.Value.Value == 1 << ua.AccessLevel.CurrentRead
                assert await s.client.get_node(variable).read_value() is False  # reads work
                assert (await _acknowledge(s)).value == ua.StatusCodes.BadUserAccessDenied

            async def operator(s: _Session) -> None:
                assert (await s.call(ARM.key, "Stop")).StatusCode.is_good()
                refused = await s.call(MEMS.key, "LoadProgram", ua.Variant(RADIAL, ua.VariantType.String))
                assert refused.StatusCode.value == ua.StatusCodes.BadUserAccessDenied, refused
                assert await s.read(ARM.key, "Stop", ua.AttributeIds.UserExecutable) is True
                assert await s.read(MEMS.key, "RunProgram", ua.AttributeIds.UserExecutable) is False
                assert (await _acknowledge(s)).is_good()

            async def engineer(s: _Session) -> None:
                loaded = await s.call(MEMS.key, "LoadProgram", ua.Variant(RADIAL, ua.VariantType.String))
                assert loaded.StatusCode.is_good(), loaded
                assert await s.read(MEMS.key, "RunProgram", ua.AttributeIds.UserExecutable) is True

            async def anonymous(s: _Session) -> None:  # anonymous_role Observer here
                result = await s.call(ARM.key, "Reset")
                assert result.StatusCode.value == ua.StatusCodes.BadUserAccessDenied, result

            with caplog.at_level(logging.WARNING):
                await _as(url, "viewer", viewer)
                await _as(url, "operator", operator)
                await _as(url, "engineer", engineer)
                await _as(url, None, anonymous)
        finally:
            await gateway.stop()

    asyncio.run(main())
    assert recorder.calls == [(ARM.key, "Stop"), (MEMS.key, "LoadProgram")]
    refusals = [r.getMessage() for r in caplog.records if "BadUserAccessDenied" in r.getMessage()]
    assert any("Stop refused: user viewer is Observer" in line for line in refusals), refusals
    assert any("Reset refused: user anonymous is Observer" in line for line in refusals), refusals
    assert any(
        "Acknowledge" in r.getMessage() and "viewer is Observer" in r.getMessage() for r in caplog.records
    )


def test_a_users_file_entry_without_a_role_is_one_error_naming_the_user(tmp_path: Path) -> None:
    path = tmp_path / "users.yaml"
    path.write_text(f"users:\n  plc: {hash_password(PASSWORD, iterations=1000)}\n")
    with pytest.raises(InputError) as error:
        load_users(str(path))
    assert "users.plc" in str(error.value) and "has no role" in str(error.value)
    assert "\n" not in str(error.value)
    path.write_text(f'users:\n  plc: {{role: Admin, hash: "{hash_password(PASSWORD, iterations=1000)}"}}\n')
    with pytest.raises(InputError, match=r"users\.plc\.role: must be one of Observer, Operator, Engineer"):
        load_users(str(path))
