"""A goal's feedback and result in the gateway's variables, ROS-free: the order DDS does not keep.

The device sends a goal's last feedback before its result, but the feedback topic and the result service
are two DDS writers, and the gateway may get the result first (ci35: a PLC read Feedback/Throws 10 beside
Result/Throws 11 once ResultCount had moved). These drive the GoalRunner's callbacks in that order.
"""

from __future__ import annotations

import threading
from concurrent.futures import Future
from typing import Any, cast

from feeder_cell.gateway.config import DeviceEntry
from feeder_cell.gateway.device_link import DeviceLink
from feeder_cell.gateway.goals import GoalRunner
from feeder_cell.gateway.kinds import throwing_arm
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Values
from feeder_msgs.action import FeedPart


class Posts:
    """The gateway server's post_all, kept: the variables as a PLC would read them after each publish."""

    def __init__(self) -> None:
        self.variables: Values = {}
        self.lock = threading.Lock()

    def post_all(self, _key: str, values: Values, _stamp_ns: int = 0) -> None:
        with self.lock:
            self.variables.update(values)


def _arm() -> tuple[GoalRunner, DeviceLink, Posts]:
    posts = Posts()
    link = DeviceLink(
        entry=DeviceEntry("throwing_arm", "/cell/throwing_arm"),
        profile=throwing_arm.PROFILE,
        triggers={},
        change_state=cast(Any, None),  # not used by a goal's callbacks
        services={},
        availability={},
        action=cast(Any, None),
    )
    return GoalRunner(cast(GatewayServer, posts)), link, posts


def _feedback(throws: int, at_rest: bool) -> Any:
    message = FeedPart.Impl.FeedbackMessage()
    message.feedback = FeedPart.Feedback(throws=throws, sensor_at_rest=at_rest)
    return message


def _result(throws: int) -> Future[Any]:
    response = FeedPart.Impl.GetResultService.Response()
    response.result = FeedPart.Result(
        outcome=FeedPart.Result.PRESENTED,
        outcome_name="PRESENTED",
        throws=throws,
        sensor_at_rest=True,
        edge=1,
    )
    done: Future[Any] = Future()
    done.set_result(response)
    return done


def test_a_result_before_the_goals_last_feedback_settles_the_feedback_variables() -> None:
    runner, link, posts = _arm()
    token, handle = object(), cast(Any, object())
    link.goal = handle
    runner._feedback(link, token, _feedback(10, False))
    runner._on_result(link, handle, token, _result(11))  # the result overtook the 11th throw's feedback
    assert posts.variables["Command.ResultCount"] == 1
    assert posts.variables["Command.Feedback.Throws"] == posts.variables["Command.Result.Throws"] == 11
    assert posts.variables["Command.Feedback.SensorAtRest"] is True
    runner._feedback(link, token, _feedback(11, True))  # late: older than what the result settled
    runner._feedback(link, token, _feedback(10, False))
    assert posts.variables["Command.Feedback.Throws"] == 11


def test_the_next_goals_feedback_is_posted_after_a_settled_result() -> None:
    runner, link, posts = _arm()
    first, second, handle = object(), object(), cast(Any, object())
    link.goal = handle
    runner._on_result(link, handle, first, _result(3))
    runner._feedback(link, second, _feedback(1, False))
    assert posts.variables["Command.Feedback.Throws"] == 1
