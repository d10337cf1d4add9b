"""What ``feeder bridge`` does unless told otherwise (light to import: ``feeder --help`` needs it, not ROS).

It listens on this machine only, on Foxglove's usual port. Clients may publish only on command topics:
the cell's nodes take their commands through services and actions (which clients call with the
``services`` capability), so the only topics a client may write by default are those named as
commands, never a sensor, a status, ``/tf`` or ``/clock``, which a viewer could otherwise forge.
"""

DEFAULT_ADDRESS = "127.0.0.1"
DEFAULT_PORT = 8765
# A topic whose last name segment is command, commands or cmd, alone or joined to other words with
# underscores: /cell/station/command, /arm_command, /cmd_vel.
DEFAULT_CLIENT_TOPICS = (r"(/\w+)*/(\w+_)?(command|commands|cmd)(_\w+)?",)
# A service call answers within this (the planners' searches are the longest, tens of seconds).
DEFAULT_SERVICE_TIMEOUT = 120.0
