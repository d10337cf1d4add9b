"""The device kit: what every simulated device shares, so that the three cannot drift apart.

- ``declarations``: ROS-free counters, faults and fault entries (what a device declares about itself);
- ``device``: ``ManagedDevice``, the lifecycle node that owns the tick, the streams, status, diagnostics,
  stop, reset, faults and parameters, built in layers of one concern each: ``core`` (the shared state and
  the device's hooks), ``status``, ``ticks`` (the tick and who drives it), ``faults``, ``lifecycle``;
  ``streams`` and ``drive`` (the lockstep driver, ROS-free) are what two of them compose;
- ``goals``: the one goal runner (``serve_goal``) that drives a device's ROS-free goal machines;
- ``rate``: the measured rate and real-time factor a device reports.

Adding a device is docs/devices.md.
"""
