"""``feeder bridge``: the live ROS graph over the Foxglove WebSocket protocol, both subprotocol names.

The WebSocket side (no ROS): ``protocol`` reads client messages and writes frames; ``ws`` is the server
(asyncio, ``websockets``: its thread, event loop and sessions); ``session`` is one client's bookkeeping
and queues, ``client_ops`` the operations clients send, ``outbound`` what the server tells them,
``adverts`` the channels, services and graph it advertises, ``backend`` what it asks of the ROS side.
The ROS side: ``server.GraphBridge`` owns the node, the work queue and the timers and hands each request
to its part: ``topics`` (channels and their subscriptions), ``services`` (called through ``calls``),
``node_parameters``, ``clock_feed`` (the cell clock), ``graph`` (the connection graph) and
``client_publishers``. ``params`` converts parameter values; ``schemas`` gives a type's ros2msg schema;
``defaults`` holds the address, port and client-publish allow-list (light to import: ``feeder --help``
needs them, not ROS). docs/bridge.md says why the protocol layer is our own.
"""
