"""The simulator nodes' ROS side that is not a node: each device's message adapters, one module a device.

``msg_<model>`` turns its model's state into the device's stream messages, its requests into model
inputs, and wraps its ROS-free goal machines for the kit's goal runner (``<Action>Goal``: feedback and
result as the action's messages). The node modules import these; these never import a node module (each
sees its node through a small protocol), so no node module imports another and there is no cycle.
"""
