"""``feeder bridge``: the live ROS graph over the Foxglove WebSocket protocol (foxglove-sdk).

``server.GraphBridge`` serves a node's graph; ``schemas.schema_of`` gives a type's ros2msg schema;
``defaults`` holds the address and port (light to import: ``feeder --help`` needs them, not foxglove).
"""
