"""A test publisher: numbered strings "SEQ SENT_NS" on /bag_seq at a fixed rate, until SIGINT or SIGTERM.

The data carries its sequence number and its wall-clock send time, so a bag can be checked against what
was sent: no gaps, and nothing missing that was sent earlier than a given moment. Prints "matched" once
a subscriber (the recorder under test) is matched, so the test times its kill from data flowing.
"""

import signal
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String

rate = float(sys.argv[1])
stop = []
signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
signal.signal(signal.SIGINT, lambda *_: stop.append(True))
node = rclpy.create_node("feeder_test_seq_talker")
publisher = node.create_publisher(
    String, "/bag_seq", QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
)
matched = False
start = time.monotonic()
seq = 0
while not stop:
    publisher.publish(String(data=f"{seq} {time.time_ns()}"))
    seq += 1
    if not matched and publisher.get_subscription_count() > 0:
        matched = True
        print("matched", flush=True)
    # Paced on the monotonic clock from the start: a late turn is caught up, the rate stays exact.
    delay = start + seq / rate - time.monotonic()
    if delay > 0:
        time.sleep(delay)
# A clean exit tells the graph at once that this publisher is gone (the next test must not see it).
node.destroy_node()
rclpy.try_shutdown()
