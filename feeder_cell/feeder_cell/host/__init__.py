"""The cell host: several nodes in one process, the lockstep among them by direct calls.

``python -m feeder_cell.host PACKAGE/EXECUTABLE ... --ros-args ...`` builds each node (its module's
``NODE``, ``PACKAGE.nodes.EXECUTABLE``) in one rclpy context and spins them on one executor. Each node keeps
everything a DDS client sees (its name, namespace, parameters, lifecycle, services, actions, topics, QoS,
``/diagnostics``): the ROS arguments are node-targeted (``-r throwing_arm:__ns:=/cell``) and the parameters
come from one params file keyed by fully qualified name, the standard ROS 2 mechanisms for a process of
several nodes. ``feeder launch`` writes both (``feeder_cell.launcher.host_command``).

When the hosted nodes include a cell clock in lockstep, it is built first and installed as the process's
lockstep hub (``feeder_planner.node_kit.lockstep.host_in_process``): the hosted devices join it by direct
calls, the clock announces each phase to them in the order they were built, and this loop answers for them
after draining the one executor, as each device's own loop does in a process of its own. Participants in
other processes (a controller, a recorder, a user's node) still take part over DDS, by the same protocol.
"""
