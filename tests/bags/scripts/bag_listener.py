"""A test subscriber to /bag_parts (volatile, as a planner that only wants new samples), until SIGINT or
SIGTERM: it makes the topic name visible in the graph before any publisher exists."""

import signal

import rclpy
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String

stop = []
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
for sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(sig, lambda *_: stop.append(True))
node = rclpy.create_node("feeder_test_bag_listener")
node.create_subscription(String, "/bag_parts", lambda msg: None, QoSProfile(depth=10))
while not stop:
    rclpy.spin_once(node, timeout_sec=0.2)
node.destroy_node()
rclpy.try_shutdown()
