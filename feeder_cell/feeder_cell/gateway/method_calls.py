"""A device method called over OPC UA, checked, handed to the ROS link, and answered.

The caller's object and role are checked, then the arguments; the call is handed to the ``Handler`` (the
ROS link), and its answer made a CallMethodResult.

Its own module because it is the gateway's one way in for commands: every refusal and every status code
a PLC receives for a call is made here (the codes of OPC 10000-4, docs/cell.md's status code table). It
runs on the asyncio loop and holds no lock; the Command variables it sets go through ``post_all``.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Mapping
from typing import Protocol, cast

from asyncua import ua

from feeder_cell.gateway import arguments, layout, roles
from feeder_cell.gateway.config import DeviceEntry
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.spec import CallContext, Goal, MethodSpec, Value
from feeder_cell.gateway.ua_casts import status_code

__all__ = ["Handler", "MethodCalls"]

# Argument-level codes of OPC 10000-4 (5.12.2.4, Call, inputArgumentResults): the call's own code is then
# Bad_InvalidArgument, and the argument's result carries the specific code.
_ARGUMENT_CODES = ("BadTypeMismatch", "BadOutOfRange")

PostAll = Callable[[str, Mapping[str, Value]], None]
MethodCall = Callable[..., Awaitable[ua.CallMethodResult]]


class Handler(Protocol):
    """What executes a checked method call (the ROS link, ``ros_link.RosLink``)."""

    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        """Run ``method`` on ``device`` with a checked call (None: a PackML command); (status, message)."""
        ...


class MethodCalls:
    """Makes each device method's asyncua callback, and the result of every call."""

    def __init__(
        self,
        handler: Handler,
        context: CallContext,
        log: logging.Logger,
        post_all: PostAll,
        node_id: Callable[[str], ua.NodeId],
    ) -> None:
        self.handler, self.context, self.log = handler, context, log
        self.post_all, self.node_id = post_all, node_id

    def method(self, device: DeviceEntry, spec: MethodSpec) -> MethodCall:
        """Return the asyncua callback of one method of one device."""
        own = self.node_id(device.key)

        async def call(parent: ua.NodeId, *variants: ua.Variant) -> ua.CallMethodResult:
            count = len(variants)
            if parent != own:
                # OPC 10000-4 5.12.2.4: the method is not a component of the object it was called on.
                return self._result(
                    device,
                    spec,
                    count,
                    "BadMethodInvalid",
                    f"{spec.name} of {device.key} is not a method of {parent.to_string()}; "
                    f"call it on {own.to_string()}",
                    -1,
                    post=False,
                )
            role, user = roles.caller_role()
            needed = roles.required_role(spec.name)
            if role < needed:
                # Not posted: a session without the right must not write the device's command channel.
                message = f"{spec.name} refused: user {user} is {role.name}; it needs {needed.name} or above"
                return self._result(device, spec, count, "BadUserAccessDenied", message, -1, post=False)
            try:
                goal = self._check(device, spec, [_from_variant(v) for v in variants])
            except arguments.ArgumentError as error:
                return self._result(device, spec, count, error.status, error.message, error.index)
            try:
                status, message = await self.handler.call(device, spec.name, goal)
            except Exception as error:  # noqa: BLE001 - a PLC gets a Bad code, the gateway keeps serving
                self.log.exception("%s.%s failed", device.key, spec.name)
                status, message = (
                    "BadInternalError",
                    f"{spec.name}: gateway error {type(error).__name__}: {error}",
                )
            return self._result(device, spec, count, status, message, -1)

        return call

    def _check(self, device: DeviceEntry, spec: MethodSpec, args: list[arguments.Argument]) -> Goal | None:
        action = KINDS[device.kind].action
        if spec.name == action.method.name:
            return action.check(spec, args, self.context)
        link = layout.service(device.kind, spec.name)
        if link is not None:
            return link.check(spec, args, self.context)
        arguments.check_count(spec, args)  # the PackML commands: no arguments, no goal
        return None

    def _result(
        self,
        device: DeviceEntry,
        spec: MethodSpec,
        count: int,
        status: str,
        message: str,
        index: int,
        post: bool = True,
    ) -> ua.CallMethodResult:
        # An argument-level code (Bad_TypeMismatch) goes into the argument's result; the call's is then
        # Bad_InvalidArgument (OPC 10000-4 5.12.2.4).
        argument_status = status
        if status in _ARGUMENT_CODES and 0 <= index < count:
            status = "BadInvalidArgument"
        if post:  # not for a call on another object: that device's command channel was not addressed
            self.post_all(device.key, {"Command.LastStatus": status, "Command.LastMessage": message})
        code = status_code(getattr(ua.StatusCodes, status, ua.StatusCodes.BadInternalError))
        result = ua.CallMethodResult()
        result.StatusCode = code
        result.OutputArguments = [ua.Variant(message, ua.VariantType.String)]
        result.InputArgumentResults = [status_code(ua.StatusCodes.Good) for _ in range(count)]
        if code.is_bad():
            self.log.warning("%s.%s: %s: %s", device.key, spec.name, argument_status, message)
            result.InputArgumentDiagnosticInfos = [ua.DiagnosticInfo() for _ in range(count)]
            targets = [index] if 0 <= index < count else list(range(count))
            for i in targets:
                if index >= 0:
                    result.InputArgumentResults[i] = status_code(
                        getattr(ua.StatusCodes, argument_status, ua.StatusCodes.BadInternalError)
                    )
                result.InputArgumentDiagnosticInfos[i] = ua.DiagnosticInfo(
                    AdditionalInfo=cast(ua.String, message)
                )
        return result


def _from_variant(variant: object) -> arguments.Argument:
    if not isinstance(variant, ua.Variant):  # a client library that passed a bare value
        variant = ua.Variant(variant)
    value = variant.Value
    return arguments.Argument(
        value, variant.VariantType.name, isinstance(value, list) or bool(variant.is_array)
    )
