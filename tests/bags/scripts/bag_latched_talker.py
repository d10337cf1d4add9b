"""A test publisher: one latched (transient-local, depth 1) string on /bag_parts, then stays up."""

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String

rclpy.init()
node = rclpy.create_node("feeder_test_latched_talker")
publisher = node.create_publisher(
    String, "/bag_parts", QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
)
publisher.publish(String(data="parts-v1"))
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
