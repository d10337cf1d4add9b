"""The reference cell controller's ROS side: what the node ``feeder_cell.nodes.cell_controller`` drives.

``link`` is the bounded waits and calls to the devices (and the lockstep wait, one quantum at a time);
``inputs`` reads the node's file parameters; ``faults`` injects the fault processes' failures;
``bring_up`` takes the devices through their lifecycle; ``stations`` does the work of the MEMS array, the
arm, the fixture and the region planner; ``squeeze`` the squeeze gripper's (``orienter: squeeze``). The
cycle and its fault policy are the ROS-free ``feeder_cell.controller``; the node wires the two together.
"""

# Import the submodules themselves: the package alone loads neither rclpy nor a message package.
__all__: list[str] = []
