"""Commands in the bag: a controller's service calls and action goals recorded with their contents.

One throwing arm (``/cmd``) for the module; a recorder (``feeder record --services --actions``) runs
while a script controller (this test's client node) calls the arm's ``~/place_part`` service and sends
a ``~/feed_part`` goal. The bag, read with the independent ``mcap`` reader and the ``mcap_ros2``
decoder, holds the call's request and response as the arm received and answered them (service
introspection, on by default in every node) and the goal's status and feedback; ``bag-info`` lists the
service with the reader's counts. ``service_introspection: off`` leaves a node's calls unpublished, and a
bad value is refused naming the parameter (``build_node`` makes that a FATAL line and exit 2).
"""

from __future__ import annotations

import math
import re
import signal
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterator

import bag_procs as bp
import pytest
import ros_harness
from mcap.reader import make_reader
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from feeder_cell.bag.info import bag_info, info_text

ARM = "/cmd/throwing_arm"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "throwing"
ARM_PARAMETERS = {
    "part_file": str(EXAMPLES / "triangle.yaml"),
    "offset": -0.005,
    "release_speed": math.radians(320),
    "gravity": -9.66,
    "mu": 0.5,
    "initial_edge": 1,
    "initial_radius": 0.12,
    "period": 0.2,
}
RECORDER = "feeder_h3_recorder"
WAIT = 30.0
REQUEST_RECEIVED, RESPONSE_SENT = 1, 2  # service_msgs/msg/ServiceEventInfo


def _answered(future: Any, timeout: float) -> bool:
    """Whether the future (completed by the client's executor thread) is done within ``timeout``."""
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    return done.wait(timeout)


def _done(future: Any, timeout: float, what: str) -> Any:
    assert _answered(future, timeout), f"{what}: no answer within {timeout:.0f} s"
    return future.result()


# Service and action parts are named Name_Event, Name_Request, Name_FeedbackMessage... (the names rosbag2
# also gives their schemas); mcap_ros2 0.6 parses ros2msg text with rosidl's .msg name rule, which has no
# underscore, so the test hands it the bag's own schema with those names joined (fields untouched).
_PART_NAME = re.compile(r"\b([A-Z][a-z][A-Za-z0-9]*)_([A-Z][A-Za-z0-9]*)\b")


def _decoded(bag: Path) -> dict[str, list[Any]]:
    """Every message of the bag decoded by mcap_ros2 from the bag's own schemas, per topic."""
    factory = DecoderFactory()
    decoders: dict[int, Any] = {}
    found: dict[str, list[Any]] = {}
    with bp.mcap_file(bag).open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert schema is not None
            if schema.id not in decoders:
                joined = Schema(
                    id=schema.id,
                    name=_PART_NAME.sub(r"\1\2", schema.name),
                    encoding=schema.encoding,
                    data=_PART_NAME.sub(r"\1\2", schema.data.decode()).encode(),
                )
                decoders[schema.id] = factory.decoder_for(channel.message_encoding, joined)
            found.setdefault(channel.topic, []).append(decoders[schema.id](message.data))
    return found


def _on_disk(bag: Path, goal_id: bytes, final: int) -> bool:
    """Whether the flushed part of the bag holds the goal's final status and the call's response."""
    from action_msgs.msg import GoalStatusArray
    from rclpy.serialization import deserialize_message

    statuses = [
        s.status
        for cdr in bp.flushed_messages(bag, f"{ARM}/feed_part/_action/status")
        for s in deserialize_message(cdr, GoalStatusArray).status_list
        if bytes(s.goal_info.goal_id.uuid) == goal_id
    ]
    responses = bp.flushed_messages(bag, f"{ARM}/place_part/_service_event")
    return final in statuses and len(responses) >= 2


@pytest.fixture(scope="module")
def session(
    launch_module_node: Callable[..., Any], ros_client: Any, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[dict[str, Any]]:
    """The arm, a recording of one service call and one goal, and what the controller saw."""
    from feeder_msgs.action import FeedPart
    from feeder_msgs.srv import ArmPlacePart
    from feeder_planner.node_kit.action_client import ActionClient

    launch_module_node("feeder_sim", "throwing_arm", ARM_PARAMETERS, namespace="/cmd")
    bag = tmp_path_factory.mktemp("commands") / "commands"
    recorder = bp.start_recorder(bag, "--services", "--actions", "--node-name", RECORDER)
    action = ActionClient(ros_client, FeedPart, f"{ARM}/feed_part")
    try:
        watched = [f"{ARM}/place_part/_service_event", f"{ARM}/feed_part/_action/status"]
        watched.append(f"{ARM}/feed_part/_action/feedback")
        bp.wait_until(
            lambda: all(bp.subscribed(ros_client, t, RECORDER) for t in watched), WAIT, "recorder subscribed"
        )
        assert action.wait_for_server(timeout_sec=WAIT)
        # The service call: the controller's command, answered by the arm.
        request = ArmPlacePart.Request(edge=2, radius=0.1)
        answer = ros_harness.call_service(ros_client, ArmPlacePart, f"{ARM}/place_part", request)
        # The goal (repeated while its answer is lost to discovery; the arm serves one goal at a time).
        deadline = time.monotonic() + WAIT
        while True:
            future = action.send_goal_async(FeedPart.Goal(max_throws=1, timeout=0.0))
            if _answered(future, 5.0):
                handle = future.result()
                break
            assert time.monotonic() < deadline, "feed_part never answered"
        assert handle.accepted
        outcome = _done(handle.get_result_async(), WAIT, "feed_part result")
        goal_id = bytes(handle.goal_id.uuid)
        # The final status and the last events travel apart from the result: wait until they are on disk.
        bp.wait_until(
            lambda: _on_disk(bag, goal_id, outcome.status),
            WAIT,
            "the goal's final status and the response on disk",
        )
        summary = bp.finish(recorder, signal.SIGINT)
    finally:
        action.destroy()
        bp.end(recorder)
    yield {
        "bag": bag,
        "summary": summary,
        "request": request,
        "answer": answer,
        "goal_id": goal_id,
        "outcome": outcome,
    }


@pytest.mark.ros
def test_a_service_call_is_in_the_bag_with_its_request_and_response(session: dict[str, Any]) -> None:
    events = _decoded(session["bag"])[f"{ARM}/place_part/_service_event"]
    kinds = [e.info.event_type for e in events]
    assert kinds == [REQUEST_RECEIVED, RESPONSE_SENT]
    received, sent = events
    assert received.info.sequence_number == sent.info.sequence_number
    (request,) = received.request
    assert (request.edge, request.radius) == (session["request"].edge, session["request"].radius)
    assert received.response == [] and sent.request == []
    (response,) = sent.response
    assert (response.ok, response.error) == (session["answer"].ok, session["answer"].error)


@pytest.mark.ros
def test_a_goal_is_in_the_bag_with_its_status_and_feedback(session: dict[str, Any]) -> None:
    from action_msgs.msg import GoalStatus

    decoded = _decoded(session["bag"])
    # Edge 2 at 10 cm is not presented within one throw: the goal ends MAX_THROWS, aborted.
    assert session["outcome"].status == GoalStatus.STATUS_ABORTED
    assert session["outcome"].result.outcome_name == "MAX_THROWS"
    statuses = [
        s.status
        for array in decoded[f"{ARM}/feed_part/_action/status"]
        for s in array.status_list
        if bytes(s.goal_info.goal_id.uuid) == session["goal_id"]
    ]
    assert statuses and statuses[-1] == GoalStatus.STATUS_ABORTED
    assert GoalStatus.STATUS_EXECUTING in statuses
    feedback = [
        f.feedback
        for f in decoded[f"{ARM}/feed_part/_action/feedback"]
        if bytes(f.goal_id.uuid) == session["goal_id"]
    ]
    assert [f.throws for f in feedback] == list(range(1, session["outcome"].result.throws + 1))


@pytest.mark.ros
def test_bag_info_lists_the_service_with_the_readers_counts(session: dict[str, Any]) -> None:
    bag = session["bag"]
    info = bag_info(bag)  # `feeder bag-info --json` prints this dict
    decoded = _decoded(bag)
    service = info["services"][f"{ARM}/place_part"]
    assert service["type"] == "feeder_msgs/srv/ArmPlacePart"
    assert (service["request_count"], service["response_count"]) == (1, 1)
    assert service["event_count"] == len(decoded[f"{ARM}/place_part/_service_event"])
    assert f"{ARM}/place_part/_service_event" not in info["topics"]  # listed as a service, not a topic
    for topic, messages in decoded.items():
        if not topic.endswith("/_service_event"):
            assert info["topics"][topic]["count"] == len(messages)
    assert (
        info["topics"][f"{ARM}/feed_part/_action/feedback"]["type"]
        == "feeder_msgs/action/FeedPart_FeedbackMessage"
    )
    text = info_text(info)  # and this without --json
    assert f"Service: {ARM}/place_part | Type: feeder_msgs/srv/ArmPlacePart | Request Count: 1" in text
    # Only commands are introspected: the parameter and lifecycle queries the harness made are not there.
    assert not any(name.endswith(("/get_state", "/get_parameters")) for name in info["services"])


def test_service_introspection_parameter(ros_client: Any) -> None:
    """contents and metadata publish a service's events, off does not; a bad word names the parameter."""
    import rclpy
    from rclpy.parameter import Parameter
    from std_srvs.srv import Trigger

    from feeder_planner.errors import InputError
    from feeder_planner.node_kit.introspection import configure_service_introspection

    def publishes_events(value: str) -> bool:
        node = rclpy.create_node(
            f"feeder_test_introspection_{value}",
            context=ros_client.context,
            parameter_overrides=[Parameter("service_introspection", value=value)],
        )
        try:
            node.create_service(Trigger, "~/go", lambda _request, response: response)
            assert configure_service_introspection(node) == value
            assert node.describe_parameter("service_introspection").read_only
            published = {name for name, _ in node.get_publisher_names_and_types_by_node(node.get_name(), "/")}
            return f"/{node.get_name()}/go/_service_event" in published
        finally:
            node.destroy_node()

    assert publishes_events("contents") and publishes_events("metadata")
    assert not publishes_events("off")
    with pytest.raises(InputError, match="service_introspection.*contents, metadata, off"):
        publishes_events("loud")
