"""In one process: a device whose own tick raises takes its error path, and the device beside it goes on.

Two kit devices driven by direct calls, as the cell host drives its devices (``feeder_device.device.hosted``,
``advance_lockstep``): the first one's model raises at its third tick. It leaves Active through the
lifecycle's error path (Deactivating, ErrorProcessing: the model released, Unconfigured), its status says
FAULT with FAULT_INTERNAL and the error, ~/reset refuses naming it, and a configure builds it again. The
second device ticks every instant all along.
"""

from __future__ import annotations

import pytest
import rclpy
from lifecycle_msgs.msg import State
from rclpy.clock import ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from std_srvs.srv import Trigger

from feeder_device.device import ManagedDevice, hosted
from feeder_device.parameters import DeviceParameters
from feeder_msgs.msg import DeviceStatus

pytestmark = pytest.mark.ros

RATE = 20.0  # Hz: two ticks a quantum
QUANTUM_NS = 100_000_000
START_NS = 1_000 * 1_000_000_000


class CountingDevice(ManagedDevice[DeviceParameters]):
    """The kit alone: its tick counts; ``raise_at`` (a tick number) makes it raise there, as a bug would."""

    raise_at = 0

    def __init__(self, name: str) -> None:
        super().__init__(name, DeviceParameters)
        self.ticked = 0
        self.released = 0

    def configure_device(self, p: DeviceParameters) -> None:
        self.expect_rate(RATE)
        self.ticked = 0

    def cleanup_device(self) -> None:
        self.released += 1

    def tick(self, now_ns: int) -> float | None:
        self.ticked += 1
        if self.ticked == self.raise_at:
            raise ZeroDivisionError("a bug in the model")
        return None


class Faulty(CountingDevice):
    raise_at = 3

    def __init__(self) -> None:
        super().__init__("faulty_device")


class Healthy(CountingDevice):
    def __init__(self) -> None:
        super().__init__("healthy_device")


def test_a_tick_that_raises_takes_the_devices_error_path_and_the_other_device_goes_on(
    ros_domain: int,
) -> None:
    assert not rclpy.ok(), "the default rclpy context is in use in this process"
    rclpy.init(
        args=["--ros-args", "-p", "use_sim_time:=true", "-p", "lockstep:=true"],
        signal_handler_options=SignalHandlerOptions.NO,
    )
    executor = SingleThreadedExecutor()
    devices: list[CountingDevice] = []
    try:
        faulty, healthy = hosted(Faulty)(), hosted(Healthy)()
        devices = [faulty, healthy]
        for device in devices:
            executor.add_node(device)
            device.get_clock().set_ros_time_override(
                Time(nanoseconds=START_NS, clock_type=ClockType.ROS_TIME)
            )
            assert device.trigger_configure() == TransitionCallbackReturn.SUCCESS
            assert device.trigger_activate() == TransitionCallbackReturn.SUCCESS

        def quantum(now_ns: int) -> None:
            for device in devices:  # what the host does: each device's clock at T, then its ticks
                device.get_clock().set_ros_time_override(
                    Time(nanoseconds=now_ns, clock_type=ClockType.ROS_TIME)
                )
                device.advance_lockstep(now_ns)

        for k in range(4):
            quantum(START_NS + k * QUANTUM_NS)
        # The faulty device raised at its third tick (the second quantum) and took its error path.
        assert faulty.ticked == 3 and faulty.released == 1
        assert faulty._state_machine.current_state[1] == "unconfigured"  # noqa: SLF001 - rcl_lifecycle's own
        status = faulty._last_status_msg  # noqa: SLF001 - what ~/status last said
        assert status is not None and status.state == DeviceStatus.FAULT
        assert status.fault_code == DeviceStatus.FAULT_INTERNAL and not status.ready
        assert "ZeroDivisionError: a bug in the model" in status.fault_text
        # The healthy one ticked every instant: two a quantum after the start.
        assert healthy.ticked == 6 and healthy.state().name == "IDLE"
        # ~/reset refuses, naming the error; configure builds the model again and clears it (the bug fixed).
        reset = faulty._on_reset(Trigger.Request(), Trigger.Response())  # noqa: SLF001 - the service's handler
        assert not reset.success and "internal error in the tick" in reset.message
        faulty.raise_at = 0
        assert faulty.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert faulty.state().name == "PAUSED" and faulty._last_status_msg.fault_code == 0  # noqa: SLF001
        assert faulty.trigger_activate() == TransitionCallbackReturn.SUCCESS
        quantum(START_NS + 5 * QUANTUM_NS)
        assert (
            faulty.state().name == "IDLE"
            and faulty._state_machine.current_state[0] == State.PRIMARY_STATE_ACTIVE
        )  # noqa: SLF001
    finally:
        executor.shutdown(timeout_sec=5.0)
        for device in devices:
            device.destroy_node()
        rclpy.try_shutdown()
