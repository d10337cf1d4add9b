"""Service introspection: every node publishes its service calls, so that a bag shows the commands.

ROS 2 (Jazzy) publishes, per introspected service, ``<service>/_service_event`` messages of type
``<pkg>/srv/<Name>_Event``: one when a request is received and one when the response is sent (server),
one when a request is sent and one when the response arrives (client), each with the request or
response contents (``contents``), or only the event's metadata (``metadata``). ``feeder record
--services`` records these topics.

Only commands are introspected: the read-only queries every node serves (parameter listing and
reading, type descriptions, lifecycle state queries) are polled by tools and would bury the commands.
A managed node's own lifecycle services (``~/change_state``...) cannot be introspected from Python (see
:func:`configure_service_introspection`); a client's lifecycle calls are, and every transition is on
the node's ``~/transition_event`` topic.
Action servers and clients cannot be introspected in Jazzy's rclpy (rcl_action gained introspection
after Jazzy): their goals and results are not published; their ``_action/feedback`` and
``_action/status`` topics are, and are recorded by ``feeder record --actions``.
"""

from __future__ import annotations

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.service_introspection import ServiceIntrospectionState

from feeder_planner.node_kit.parameters import ParameterSpec, declare_parameters, one_of

__all__ = ["INTROSPECTION_PARAMETER", "QUERY_SERVICES", "STATES", "configure_service_introspection"]

INTROSPECTION_PARAMETER = "service_introspection"

STATES = {
    "contents": ServiceIntrospectionState.CONTENTS,
    "metadata": ServiceIntrospectionState.METADATA,
    "off": ServiceIntrospectionState.OFF,
}

# Last name component of the read-only queries left out (see the module docstring).
QUERY_SERVICES = frozenset(
    {
        "describe_parameters",
        "get_parameters",
        "get_parameter_types",
        "list_parameters",
        "get_type_description",
        "get_state",
        "get_available_states",
        "get_available_transitions",
        "get_transition_graph",
    }
)

SPEC = ParameterSpec(
    INTROSPECTION_PARAMETER,
    "contents",
    "service introspection of this node's services and clients (their calls on <service>/_service_event): "
    "contents (request and response fields), metadata (event kind, time, caller and sequence only) or off; "
    "read-only queries (parameters, lifecycle state, type descriptions) are never introspected",
    one_of(tuple(STATES)),
    read_only=True,
)

# Reliable and deep: a burst of calls must reach a recorder even while it is writing to disk.
EVENT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


def configure_service_introspection(node: Node) -> str:
    """Declare ``service_introspection`` and apply it to every command service and client of ``node``.

    Call it once the node has created its services and clients (``runner.build_node`` does).

    Parameters
    ----------
    node
        The node whose services and clients to introspect.

    Returns
    -------
    str
        The state applied: ``contents``, ``metadata`` or ``off``.

    Raises
    ------
    InputError
        The parameter is not one of the three words.
    """
    if node.has_parameter(INTROSPECTION_PARAMETER):
        value = node.get_parameter(INTROSPECTION_PARAMETER).value
    else:
        value = declare_parameters(node, [SPEC])[INTROSPECTION_PARAMETER]
    state = STATES[value]
    if state == ServiceIntrospectionState.OFF:
        return value  # OFF is every service's initial state: nothing to configure
    clock = node.get_clock()
    for service in node.services:
        if service.srv_name.rsplit("/", 1)[-1] in QUERY_SERVICES:
            continue
        if service.srv_type.__module__.startswith("lifecycle_msgs."):
            # The lifecycle state machine's own services are made in C (rcl_lifecycle) without the type
            # support introspection needs: configuring them crashes the process. Their effect is public:
            # every transition is published on ~/transition_event, which is recorded like any topic.
            continue
        service.configure_introspection(clock, EVENT_QOS, state)
    for client in node.clients:
        if client.srv_name.rsplit("/", 1)[-1] not in QUERY_SERVICES:
            client.configure_introspection(clock, EVENT_QOS, state)
    return value
