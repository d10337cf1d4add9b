"""The OPC UA gateway for PLC cell controllers: devices over DDS exposed as OPC UA objects (asyncua).

``config`` (parameters, security rules, the PackML mapping), ``layout`` (the address space as data),
``arguments`` (method arguments checked, naming the argument) and ``users`` (salted password hashes) are
ROS-free; ``server`` wires asyncua; ``ros_link`` is the ROS (DDS) side. The node:
``feeder_cell.nodes.opcua_gateway``.
"""

# Import the submodules themselves (the ROS-free ones need neither rclpy nor asyncua).
__all__: list[str] = []
