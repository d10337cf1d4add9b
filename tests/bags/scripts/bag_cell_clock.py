"""A test cell clock: /cell_time (std_msgs/String) from the start, /clock only after a delay.

Usage: bag_cell_clock.py DELAY_S START_S FACTOR. Every 20 ms of wall time it publishes /cell_time; before
DELAY_S its data is "pre" (no cell time yet), after it the cell time in ns, which /clock carries too, the
cell clock starting at START_S and running FACTOR times faster than wall time. Prints "clock" when /clock
starts. Ends on SIGINT or SIGTERM.
"""

import signal
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String

delay, start_s, factor = (float(a) for a in sys.argv[1:4])
stop = []
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
for sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(sig, lambda *_: stop.append(True))
node = rclpy.create_node("feeder_test_cell_clock")
reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
data = node.create_publisher(String, "/cell_time", reliable)
clock = node.create_publisher(Clock, "/clock", reliable)
began = time.monotonic()
clock_began = None
while not stop:
    now = time.monotonic()
    if now - began < delay:
        data.publish(String(data="pre"))
    else:
        if clock_began is None:
            clock_began = now
            print("clock", flush=True)
        cell = int(start_s * 1e9 + (now - clock_began) * factor * 1e9)
        tick = Clock()
        tick.clock.sec, tick.clock.nanosec = divmod(cell, 1_000_000_000)
        clock.publish(tick)
        data.publish(String(data=str(cell)))
    time.sleep(0.02)
node.destroy_node()
rclpy.try_shutdown()
