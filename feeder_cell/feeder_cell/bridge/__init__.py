"""``feeder bridge``: the live ROS graph over the Foxglove WebSocket protocol, both subprotocol names.

``protocol`` reads client messages and writes frames (no ROS); ``ws`` is the WebSocket server (asyncio,
``websockets``; no ROS); ``server.GraphBridge`` is the ROS side (topics, services, parameters, the
graph, the cell clock, client publishing); ``params`` converts parameter values; ``schemas`` gives a
type's ros2msg schema; ``defaults`` holds the address, port and client-publish allow-list (light to
import: ``feeder --help`` needs them, not ROS). docs/bridge.md says why the protocol layer is our own.
"""
