"""A test publisher for the record controls: /ctl/a (String), /ctl/b (Int32), the hidden /ctl/_hidden/c
(String), each at RATE Hz with a sequence number, until SIGINT or SIGTERM.

Prints "matched N" once N subscriptions are matched on /ctl/a, so a test starts counting from data flowing.
"""

import signal
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Int32, String

rate = float(sys.argv[1])
stop = []
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
for sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(sig, lambda *_: stop.append(True))
node = rclpy.create_node("feeder_test_mixed_talker")
qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
a = node.create_publisher(String, "/ctl/a", qos)
b = node.create_publisher(Int32, "/ctl/b", qos)
c = node.create_publisher(String, "/ctl/_hidden/c", qos)
start = time.monotonic()
seq = 0
matched = 0
while not stop:
    a.publish(String(data=str(seq)))
    b.publish(Int32(data=seq))
    c.publish(String(data=str(seq)))
    seq += 1
    if a.get_subscription_count() > matched:
        matched = a.get_subscription_count()
        print(f"matched {matched}", flush=True)
    delay = start + seq / rate - time.monotonic()
    if delay > 0:
        time.sleep(delay)
node.destroy_node()
rclpy.try_shutdown()
