"""Replay regression: a recorded MEMS cell run, played with ``--clock`` into a fresh equilibria planner
running on sim time, makes the planner publish the same predictions, byte for byte, as in the recording.

What "the same" means: the planner publishes ``~/predicted_poses`` from a timer (2 Hz of its node clock)
when the prediction changed, from the latest program, parts and part states it received. Its timer's
phase is arbitrary in both runs, so the stamps (node-clock time of the timer call: wall time in the
recording, bag time in the replay) cannot match and are left out (set to zero); everything else in the
CDR bytes (frame, field, delta, names, poses, angles) must be identical, message for message, in the
same order. The run is made so that the prediction depends on no sampling instant: the program holds
one combined field from the start (the part stays in the basin the prediction names), and once during
the recording the test replaces it by another (delta 0.3 -> 0.5), so there are exactly two predictions.
The replay's stamps must lie in the bag's time: the planner's clock followed /clock.
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from typing import Any

import bag_procs as bp
import pytest
import ros_harness
import yaml
from rclpy.serialization import deserialize_message

from feeder_msgs.msg import EquilibriaPrediction, FieldProgram, FieldSpec
from feeder_msgs.srv import FieldSetProgram
from feeder_planner.node_kit import LATCHED

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"
ARRAY, PLANNER = "/mems_field_array", "/field_equilibria_planner"
INPUTS = (f"{ARRAY}/field_program", f"{ARRAY}/parts", f"{ARRAY}/part_states")
OUTPUT = f"{PLANNER}/predicted_poses"
# The replay goes to other names (the player remaps), so nothing of the original run can reach it.
REPLAY_DEVICE = "/replay/mems_field_array"
REPLAY_OUTPUT = "/replay_planner/predicted_poses"


def _without_stamp(cdr: bytes) -> bytes:
    # CDR: 4 bytes encapsulation, then header.stamp (int32 sec, uint32 nanosec).
    return cdr[:4] + bytes(8) + cdr[12:]


def _stamp_ns(cdr: bytes) -> int:
    return int.from_bytes(cdr[4:8], "little", signed=True) * 1_000_000_000 + int.from_bytes(
        cdr[8:12], "little"
    )


def _start(started: list, log_dir: Path, executable: str, parameters: dict, name: str = "") -> Any:
    package = "feeder_sim" if executable == "mems_field_array" else "feeder_planner"
    node = ros_harness.start_node(package, executable, parameters, log_dir, name=name)
    started.append(node)
    return node


def _hold(bag: Path, states: int = 30) -> None:
    """Wait until ``states`` more part states (at 20 Hz) are on disk in the bag being recorded."""
    mark = len(bp.flushed_messages(bag, INPUTS[2]))
    bp.wait_until(lambda: len(bp.flushed_messages(bag, INPUTS[2])) >= mark + states, 30, "recorded states")


@pytest.mark.ros
def test_replay_into_the_planner_reproduces_its_predictions(
    ros_client: Any, listen: Any, started_processes: list, tmp_path: Path
) -> None:
    program = tmp_path / "combined.yaml"
    program.write_text(yaml.safe_dump({"steps": [{"field": {"type": "combined", "delta": 0.3}}]}))
    recorded = tmp_path / "recorded"
    predictions = listen(EquilibriaPrediction, OUTPUT, latched=True)
    replayed: list[bytes] = []
    arrived = threading.Event()

    def on_replayed(data: bytes) -> None:
        replayed.append(data)
        if len(replayed) >= 2:
            arrived.set()

    # Raw: the bytes as the planner serialised them, as the recorder stores them.
    ros_client.create_subscription(EquilibriaPrediction, REPLAY_OUTPUT, on_replayed, LATCHED, raw=True)

    # The recorder, the array, its planner and the replay's planner (on sim time: idle until /clock
    # arrives, and listening to names only the player's remapped topics use) start side by side.
    recorder = bp.start_recorder(recorded, "--topics", *INPUTS, OUTPUT, "--flush-interval", "0.2")
    nodes = [
        _start(
            started_processes,
            tmp_path,
            "mems_field_array",
            {
                "fidelity": "ideal",
                "part_files": [str(EXAMPLES / "plus.yaml")],
                "program_file": str(program),
                "seed": 7,
                "time_step": 5e-4,
                "publish_rate": 20.0,
                # The run's commands are not what is compared, nor recorded.
                "service_introspection": "off",
            },
        ),
        _start(started_processes, tmp_path, "field_equilibria_planner", {}),
        _start(
            started_processes,
            tmp_path,
            "field_equilibria_planner",
            {"use_sim_time": True, "device": REPLAY_DEVICE},
            name="replay_planner",
        ),
    ]
    try:
        for node in nodes:
            ros_harness.wait_for_graph_node(ros_client, node, node.spec.node_name)
        ros_harness.bring_to(ros_client, nodes[0], "active")
        ros_harness.wait_for_graph(ros_client, None, (*INPUTS, OUTPUT, REPLAY_OUTPUT))

        # --- the original run: array and planner on wall time, recorded with their output -----------
        for topic in (*INPUTS, OUTPUT):
            bp.wait_until(
                lambda t=topic: bp.subscribed(ros_client, t, "feeder_recorder"), 30, f"recording {topic}"
            )
        predictions.wait(lambda m: m.delta == 0.3, timeout=30, current=True)
        # Each program holds for 1.5 s of states in the bag (three of the planner's 0.5 s periods), so
        # the replay's planner, whatever its timer's phase, samples both.
        _hold(recorded)
        request = FieldSetProgram.Request(program=FieldProgram(steps=[FieldSpec(type="combined", delta=0.5)]))
        answer = ros_harness.call_service(ros_client, FieldSetProgram, f"{ARRAY}/set_program", request)
        assert answer.ok, answer.error
        predictions.wait(lambda m: m.delta == 0.5, timeout=30, current=True)
        _hold(recorded)
        bp.finish(recorder, signal.SIGINT)
        original = [data for _, data in bp.read_messages(recorded, OUTPUT)]
        assert len(original) == 2, f"{len(original)} predictions recorded, expected the two programs' ones"
        assert _without_stamp(original[0]) != _without_stamp(original[1])

        # --- the replay: the bag and its /clock drive the planner on sim time ------------------------
        remaps = [f"--remap={topic}:={REPLAY_DEVICE}{topic[len(ARRAY) :]}" for topic in INPUTS]
        player = bp.run_feeder(
            *("play", str(recorded), "--clock", "100", "--topics", *INPUTS, *remaps),
            *("--wait-for-subscribers", "30", "--linger", "0"),
        )
        assert player.returncode == 0, player.stderr
        deltas = lambda: [deserialize_message(d, EquilibriaPrediction).delta for d in replayed]  # noqa: E731
        if not arrived.wait(30):
            # ci38 (once in 4 runs, not reproduced under load here): only the second program's prediction
            # came. What the bag held, the player and the replay's planner said, for the next one.
            recorded_programs = bp.read_messages(recorded, INPUTS[0])
            programs = [
                (t, [s.delta for s in deserialize_message(d, FieldProgram).steps])
                for t, d in recorded_programs
            ]
            raise AssertionError(
                f"{len(replayed)} of {len(original)} predictions replayed, deltas {deltas()}; "
                f"the bag's programs (log time ns, delta) {programs}; "
                f"player stderr {player.stderr[-600:]!r}; "
                f"replay planner log {nodes[2].output()[-1500:]!r}"
            )
    finally:
        bp.end(recorder)
        for node in nodes:
            node.stop()
    assert [_without_stamp(d) for d in replayed] == [_without_stamp(d) for d in original]
    # The planner's clock was the bag's: its stamps lie within the recording's time span.
    # (/clock ticks every 10 ms, so a sample may carry the tick just before the state it used.)
    with_times = bp.read_messages(recorded, INPUTS[2])
    first, last = with_times[0][0] - 100_000_000, with_times[-1][0] + 1_000_000_000
    assert all(first <= _stamp_ns(d) <= last for d in replayed), [_stamp_ns(d) for d in replayed]
