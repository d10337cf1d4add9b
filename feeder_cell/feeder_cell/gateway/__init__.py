"""The OPC UA gateway for PLC cell controllers: devices over DDS exposed as OPC UA objects (asyncua).

``spec`` (the types a device kind is described in) is the bottom; ``kinds`` holds one profile per device
kind (``kinds.KINDS``: its signals and topics, its action method, arguments and goal, its counters from
the device's own declaration); ``arguments`` (the shared argument readers, naming the argument),
``layout`` (the address space as data: what every device has, plus its kind's profile), ``config``
(parameters, security rules, the PackML mapping) and ``users`` (salted password hashes) need neither a
node nor asyncua; ``server`` wires asyncua (its parts: ``address_space``, ``value_writer``,
``method_calls``, ...); ``ros_link`` is the ROS (DDS) side (its parts: ``device_listener``,
``command_runner``, ``goals``, ...). The node: ``feeder_cell.nodes.opcua_gateway``.
"""

# Import the submodules themselves: the package alone loads neither asyncua nor rclpy.
__all__: list[str] = []
