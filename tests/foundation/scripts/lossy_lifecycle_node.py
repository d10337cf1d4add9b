"""A test node serving lifecycle_msgs get_state and change_state whose first change_state reply is lost.

A managed node loses a reply when it answers before it has matched the caller's reply reader (rmw_fastrtps:
"client will not receive response"): the transition has run, or was refused, and the caller hears nothing.
This node makes that loss certain for its first transition request: it takes the request, runs the
transition, and never replies. Later requests are answered. Its configure behaves as MODE says:

- ``refuse``: configure fails, the node stays unconfigured (a bad configuration);
- ``accept``: configure succeeds, the node is inactive;
- ``slow``: configure takes SLOW_S seconds, in the state ``configuring``, then succeeds; its reply is sent.

It prints ``ready`` once it serves, and ``change_state N`` for each transition request it takes.
Usage: lossy_lifecycle_node.py MODE
"""

from __future__ import annotations

import sys

import rclpy
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.task import Future

SLOW_S = 3.0
STATES = {
    State.PRIMARY_STATE_UNCONFIGURED: "unconfigured",
    State.PRIMARY_STATE_INACTIVE: "inactive",
    State.TRANSITION_STATE_CONFIGURING: "configuring",
}


def main() -> None:
    mode = sys.argv[1]
    rclpy.init()
    node = rclpy.create_node("lossy_lifecycle")
    state = [State.PRIMARY_STATE_UNCONFIGURED]
    requests = [0]

    def get_state(_request: GetState.Request, response: GetState.Response) -> GetState.Response:
        response.current_state = State(id=state[0], label=STATES[state[0]])
        return response

    async def change_state(
        request: ChangeState.Request, response: ChangeState.Response
    ) -> ChangeState.Response:
        requests[0] += 1
        print(f"change_state {requests[0]}", flush=True)
        first = requests[0] == 1
        if (
            request.transition.id != Transition.TRANSITION_CONFIGURE
            or state[0] != State.PRIMARY_STATE_UNCONFIGURED
        ):
            response.success = False
        elif mode == "refuse":
            response.success = False
        elif mode == "accept":
            state[0] = State.PRIMARY_STATE_INACTIVE
            response.success = True
        else:  # slow
            state[0] = State.TRANSITION_STATE_CONFIGURING
            done = Future()
            timer = node.create_timer(SLOW_S, lambda: done.set_result(True))
            await done
            node.destroy_timer(timer)
            state[0] = State.PRIMARY_STATE_INACTIVE
            response.success = True
            return response
        if first:
            await Future()  # never done: the reply to the first request is lost
        return response

    # Reentrant: get_state is answered while a change_state callback waits (a slow or a lost reply).
    group = ReentrantCallbackGroup()
    node.create_service(GetState, "~/get_state", get_state, callback_group=group)
    node.create_service(ChangeState, "~/change_state", change_state, callback_group=group)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    print("ready", flush=True)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
