"""A test publisher on /bag_parts, then stays up until SIGINT or SIGTERM.

``bag_latched_talker.py latched NAME DATA``: one transient-local (depth 1) sample, as the MEMS array's
~/parts. ``bag_latched_talker.py volatile NAME DATA``: a volatile sample every 0.2 s.
"""

import signal
import sys

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String

kind, name, data = sys.argv[1:4]
stop = []
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
for sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(sig, lambda *_: stop.append(True))
node = rclpy.create_node(name)
durability = DurabilityPolicy.TRANSIENT_LOCAL if kind == "latched" else DurabilityPolicy.VOLATILE
publisher = node.create_publisher(String, "/bag_parts", QoSProfile(depth=1, durability=durability))
publisher.publish(String(data=data))
while not stop:
    rclpy.spin_once(node, timeout_sec=0.2)
    if kind == "volatile":
        publisher.publish(String(data=data))
# A clean exit tells the graph at once that this publisher is gone (the next test must not see it).
node.destroy_node()
rclpy.try_shutdown()
