"""Helper process of ``feeder doctor``: echoes std_msgs/String from one topic to another."""

from __future__ import annotations

import sys


def main() -> int:
    """Echo one message over DDS (the doctor's round-trip probe); return the exit status."""
    import rclpy
    from rclpy.node import Node
    from std_msgs.msg import String

    request_topic, reply_topic, lifetime_s = sys.argv[1], sys.argv[2], float(sys.argv[3])
    rclpy.init()
    node = Node("feeder_doctor_echo")
    publisher = node.create_publisher(String, reply_topic, 10)
    node.create_subscription(String, request_topic, publisher.publish, 10)
    deadline = node.get_clock().now().nanoseconds + int(lifetime_s * 1e9)
    try:
        while rclpy.ok() and node.get_clock().now().nanoseconds < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
