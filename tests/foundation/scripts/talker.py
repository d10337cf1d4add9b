"""A test publisher process: N numbered strings on /talk and one latched message on /latched."""

import sys

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String

count, period = int(sys.argv[1]), float(sys.argv[2])
rclpy.init()
node = rclpy.create_node("feeder_test_talker")
talk = node.create_publisher(String, "/talk", 10)
latched = node.create_publisher(
    String, "/latched", QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
)
latched.publish(String(data="latched-hello"))
# Volatile messages reach only subscribers already matched: wait (bounded) for the recorder.
waited = 0.0
while talk.get_subscription_count() == 0 and waited < 30.0:
    rclpy.spin_once(node, timeout_sec=0.1)
    waited += 0.1
for i in range(count):
    talk.publish(String(data=f"msg-{i}"))
    rclpy.spin_once(node, timeout_sec=period)
rclpy.spin_once(node, timeout_sec=1.0)
node.destroy_node()
rclpy.try_shutdown()
