"""The gateway's address space made nodes: the Cell, its alarms, the devices, their enumeration types.

Objects/Cell, its alarms, one object per device with its variables (typed, described, with units) and
methods, and the enumeration DataTypes they use.

Separate from the server's start because what it builds is the layout (``layout``, data) made nodes, once,
on the asyncio loop before the server listens; it holds no lock. The variables' types it records
(``types``) are what the value writer writes them with, and the methods' least roles (``method_roles``)
what ``roles.enforce`` checks.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import cast

from asyncua import Node, Server, ua

from feeder_cell.gateway import layout, roles, units
from feeder_cell.gateway.alarms import Alarms
from feeder_cell.gateway.config import PACKML_STATES, DeviceEntry
from feeder_cell.gateway.method_calls import MethodCall
from feeder_cell.gateway.roles import Role
from feeder_cell.gateway.spec import ArgumentSpec, MethodSpec, Value, VariableSpec
from feeder_cell.gateway.ua_casts import node_id, status_code

__all__ = ["AddressSpace"]

# Variables written by the gateway itself start Good; those mirrored from DDS start
# BadWaitingForInitialData until the device's first sample.
_OWN_PREFIXES = ("Kind", "NodeName", "Command.", "Status.Online", "Status.PackMLState")
# Initial values other than the type's zero: no status heard yet is PackML Undefined (code 0).
_INITIAL: dict[str, Value] = {"Status.PackMLState": "Undefined"}

Post = Callable[[str, str, Value], None]
MakeMethod = Callable[[DeviceEntry, MethodSpec], MethodCall]


class AddressSpace:
    """Builds the cell's nodes in a server's namespace ``idx``; the alarms are made with them."""

    def __init__(
        self,
        server: Server,
        idx: int,
        devices: tuple[DeviceEntry, ...],
        log: logging.Logger,
        types: dict[str, ua.VariantType],
        method_roles: dict[ua.NodeId, Role],
        post: Post,
        method: MakeMethod,
    ) -> None:
        self.server, self.idx, self.devices, self.log = server, idx, devices, log
        self.types, self.method_roles = types, method_roles
        self.post, self.method = post, method
        self.alarms: Alarms | None = None

    def _id(self, identifier: str) -> ua.NodeId:
        return node_id(identifier, self.idx)

    def _name(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(name, self.idx)

    async def build(self) -> None:
        """Add the enumerations, the Cell object, its alarms and every device."""
        server = self.server
        await self._enumerations()
        cell = await server.nodes.objects.add_object(self._id(layout.CELL), self._name("Cell"))
        self.alarms = Alarms(server, self.idx, self.log, cell)
        await self.alarms.setup()
        folder = await cell.add_folder(self._id(layout.DEVICES_FOLDER), self._name("Devices"))
        for device in self.devices:
            await self._add_device(folder, device)
        for method in self.alarms.acknowledge_methods:
            self.method_roles[method] = Role.Operator

    async def _add_device(self, folder: Node, device: DeviceEntry) -> None:
        key = device.key
        obj = await folder.add_object(self._id(key), self._name(key))
        await self._describe(obj, f"{device.kind} {device.node}")
        parents: dict[str, Node] = {"": obj}
        for spec in layout.variables(device.kind):
            await self._add_device_variable(parents, key, spec)
        if self.alarms is not None:
            await self.alarms.add_device(key, obj)
        self.post(key, "Kind", device.kind)
        self.post(key, "NodeName", device.node)
        await self._add_methods(obj, device)

    async def _add_device_variable(self, parents: dict[str, Node], key: str, spec: VariableSpec) -> None:
        """Add one variable of a device: its folders, type, description, units, initial value and status."""
        *folders, name = spec.path.split(".")
        parent = await self._folder(parents, key, folders)
        vtype = ua.VariantType[spec.type]
        vid = layout.variable_id(key, spec.path)
        initial = [] if spec.array else _INITIAL.get(spec.path, _default(vtype))
        analog = ua.ObjectIds.BaseAnalogType if spec.unit else ua.ObjectIds.BaseDataVariableType
        node = await _add_variable(
            parent, self._id(vid), self._name(name), ua.Variant(initial, vtype), analog
        )
        if spec.array:
            await node.write_attribute(
                ua.AttributeIds.ValueRank,
                ua.DataValue(ua.Variant(ua.ValueRank.OneDimension, ua.VariantType.Int32)),
            )
        await self._describe(node, spec.description)
        if spec.unit:
            await self._engineering_units(node, vid, spec.unit)
        if spec.data_type:
            await node.write_attribute(
                ua.AttributeIds.DataType,
                ua.DataValue(ua.Variant(self._id(spec.data_type), ua.VariantType.NodeId)),
            )
        self.types[vid] = vtype
        if not spec.path.startswith(_OWN_PREFIXES):
            await self.server.write_attribute_value(
                node.nodeid,
                ua.DataValue(StatusCode=status_code(ua.StatusCodes.BadWaitingForInitialData)),
            )

    async def _add_methods(self, obj: Node, device: DeviceEntry) -> None:
        key = device.key
        for spec_m in layout.methods(device.kind):
            self.method_roles[self._id(layout.method_id(key, spec_m.name))] = roles.required_role(spec_m.name)
            await obj.add_method(
                self._id(layout.method_id(key, spec_m.name)),
                self._name(spec_m.name),
                self.method(device, spec_m),
                [_argument(a) for a in spec_m.inputs],
                [_argument(ArgumentSpec("Message", "String", "what the gateway or the device says"))],
            )

    async def _folder(self, parents: dict[str, Node], key: str, folders: list[str]) -> Node:
        path = ""
        for name in folders:
            child = f"{path}.{name}" if path else name
            if child not in parents:
                parents[child] = await parents[path].add_folder(self._id(f"{key}.{child}"), self._name(name))
            path = child
        return parents[path]

    async def _enumerations(self) -> None:
        """Add the enumeration DataTypes: PackML's, the device state's, each kind's outcomes."""
        await self._enumeration(
            layout.PACKML_STATE_TYPE,
            "PackML state: ISA-TR88.00.02 StateCurrent numbers; 100 Unconfigured",
            PACKML_STATES,
        )
        kinds = sorted({d.kind for d in self.devices})
        for name, fields in layout.enumerations(kinds).items():
            await self._enumeration(name, name.removesuffix("Enumeration"), fields)

    async def _enumeration(self, name: str, text: str, fields: layout.Fields) -> None:
        """Add an Enumeration subtype with EnumValues (OPC 10000-3) named ``name``.

        PackML's numbers are not contiguous (Unconfigured is 100), so each carries EnumValues, not
        EnumStrings, and its DataTypeDefinition (an EnumDefinition) for clients that build types from it.
        """
        dtype = await self.server.nodes.enum_data_type.add_data_type(self._id(name), self._name(name))
        await self._describe(dtype, text)
        definition = ua.EnumDefinition()
        values = []
        for number, state, meaning in fields:
            definition.Fields.append(
                ua.EnumField(
                    Value=cast(ua.Int64, number),
                    DisplayName=ua.LocalizedText(state),
                    Description=ua.LocalizedText(meaning),
                    Name=cast(ua.String, state),
                )
            )
            values.append(
                ua.EnumValueType(
                    Value=cast(ua.Int64, number),
                    DisplayName=ua.LocalizedText(state),
                    Description=ua.LocalizedText(meaning),
                )
            )
        await dtype.write_data_type_definition(definition)
        prop = await dtype.add_property(
            self._id(f"{name}.EnumValues"),
            ua.QualifiedName("EnumValues", 0),
            ua.Variant(values, ua.VariantType.ExtensionObject),
            datatype=node_id(ua.ObjectIds.EnumValueType),
        )
        await prop.write_attribute(
            ua.AttributeIds.ValueRank,
            ua.DataValue(ua.Variant(ua.ValueRank.OneDimension, ua.VariantType.Int32)),
        )

    async def _engineering_units(self, node: Node, vid: str, code: str) -> None:
        """Give a BaseAnalogType variable its EngineeringUnits property (OPC 10000-8, 5.3.2)."""
        unit = units.UNITS[code]
        info = ua.EUInformation(
            NamespaceUri=cast(ua.String, units.UNECE_NAMESPACE),
            UnitId=cast(ua.Int32, units.unit_id(code)),
            DisplayName=ua.LocalizedText(unit.symbol),
            Description=ua.LocalizedText(unit.name),
        )
        await node.add_property(
            self._id(f"{vid}.EngineeringUnits"),
            ua.QualifiedName("EngineeringUnits", 0),
            ua.Variant(info, ua.VariantType.ExtensionObject),
            datatype=node_id(ua.ObjectIds.EUInformation),
        )

    @staticmethod
    async def _describe(node: Node, text: str) -> None:
        await node.write_attribute(
            ua.AttributeIds.Description,
            ua.DataValue(ua.Variant(ua.LocalizedText(text), ua.VariantType.LocalizedText)),
        )


def _default(vtype: ua.VariantType) -> Value:
    if vtype == ua.VariantType.Boolean:
        return False
    if vtype == ua.VariantType.String:
        return ""
    if vtype in (ua.VariantType.Double, ua.VariantType.Float):
        return 0.0
    return 0


async def _add_variable(
    parent: Node, nodeid: ua.NodeId, name: ua.QualifiedName, value: ua.Variant, type_definition: int
) -> Node:
    """Add a read-only variable of the given VariableType, a HasComponent of ``parent``.

    asyncua's ``add_variable`` makes a BaseDataVariableType; swapping the node's HasTypeDefinition
    afterwards leaves the parent's reference (what Browse returns as TypeDefinition) stale, so the type is
    the AddNodes request's own.
    """
    item = ua.AddNodesItem()
    item.RequestedNewNodeId, item.BrowseName = nodeid, name
    item.NodeClass = ua.NodeClass.Variable
    item.ParentNodeId = parent.nodeid
    item.ReferenceTypeId = node_id(ua.ObjectIds.HasComponent)
    item.TypeDefinition = node_id(type_definition)
    attrs = ua.VariableAttributes()
    attrs.DisplayName = attrs.Description = ua.LocalizedText(name.Name)
    attrs.DataType = node_id(value.VariantType.value)
    attrs.Value = value
    array = isinstance(value.Value, list)
    attrs.ValueRank = ua.ValueRank.OneDimension if array else ua.ValueRank.Scalar
    attrs.WriteMask = attrs.UserWriteMask = cast(ua.UInt32, 0)
    attrs.AccessLevel = attrs.UserAccessLevel = cast(ua.Byte, ua.AccessLevel.CurrentRead.mask)
    attrs.Historizing = False
    item.NodeAttributes = attrs
    result = (await parent.session.add_nodes([item]))[0]
    result.StatusCode.check()
    return Node(parent.session, result.AddedNodeId)


def _argument(spec: ArgumentSpec) -> ua.Argument:
    arg = ua.Argument()
    arg.Name = spec.name
    arg.DataType = node_id(ua.VariantType[spec.type].value)
    arg.ValueRank = ua.ValueRank.OneDimension if spec.array else ua.ValueRank.Scalar
    arg.ArrayDimensions = [0] if spec.array else []
    arg.Description = ua.LocalizedText(spec.description)
    return arg
