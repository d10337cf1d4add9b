"""A test subscriber to /bag_parts (volatile, as a planner that only wants new samples): makes the topic
name visible in the graph before any publisher exists."""

import rclpy
from rclpy.qos import QoSProfile
from std_msgs.msg import String

rclpy.init()
node = rclpy.create_node("feeder_test_bag_listener")
node.create_subscription(String, "/bag_parts", lambda msg: None, QoSProfile(depth=10))
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
