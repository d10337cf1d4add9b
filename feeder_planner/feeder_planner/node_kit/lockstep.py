"""Lockstep: the protocol by which a node holds the cell clock until its work up to a cell time is done.

The cell clock (``feeder_cell`` ``cell_clock`` with ``lockstep: true``, which ``feeder launch
--real-time-factor`` starts) advances cell time by one quantum only when every participant has
finished with the present one, so no device drops a step or a sample whatever the host's speed, and a
seed gives the same run at any pace. Each quantum T has three phases, one per role, in this order:

=========  ==============================  =========================  ========================================
role       the clock announces T on        the participant answers    what the participant does before
=========  ==============================  =========================  ========================================
tick       ``/lockstep/tick``              ``/lockstep/ticked``       simulate up to T and publish every
           (std_msgs/Header)                                          sample up to T (devices)
react      ``/lockstep/settled``           ``/lockstep/reacted``      decide on what every tick participant
           (std_msgs/Header)                                          produced up to T, send its requests and
                                                                      wait for their answers (controllers)
observe    ``/lockstep/quiet``             ``/lockstep/observed``     take in everything the quantum produced
           (std_msgs/Header)                                          (recorders)
=========  ==============================  =========================  ========================================

A participant runs on sim time and sets its node clock to T as it hears its announcement (``/clock`` itself is
published at most ``clock_rate`` times per wall second, for the nodes that do not join: they see a faster,
coarser clock and are not woken once per quantum). An answer is a ``std_msgs/Header``: ``frame_id`` the node's
fully qualified name without its leading slash (a frame id never starts with one), ``stamp`` the cell time it
is done with. The first answer joins (any stamp; the node is waited for from the next quantum on);
``stamp.sec == -1`` leaves. Answers must be published reliably. A participant that does not answer within
the clock's ``lockstep_timeout`` (wall seconds) is dropped from the lockstep with an ERROR in ``/diagnostics``
naming it. A node that does not join simply sees a faster ``/clock``.

Announcements and answers are ``std_msgs/Header`` (``stamp`` T), an unbounded type on purpose: Fast DDS
delivers a bounded type (``rosgraph_msgs/Clock``) between processes of one host by data sharing, a path of
its own, so an announcement could overtake the samples a device sent before its answer (a recorder then
logged a joint state one quantum late: seen once in CI); unbounded types all take the shared-memory
transport, where what reaches one process arrives in the order it was sent.

**In one process** (``feeder_cell``'s cell host, docs/cell.md): a node built while a ``Hub`` is installed
(``host_in_process``) takes part by direct calls instead: the hub, the hosted cell clock, calls ``arrive(T)``
in its phase, and ``send`` hands the answer to the hub; no lockstep message goes through DDS. The host's
loop spins the one executor of all its nodes and calls ``answer_pending`` of every hosted participant after
each turn, so the drain before an answer is the same as in a process of its own.

Why the phases: DDS delivers the messages one process sends to another in order, and a participant
answers only after it has sent everything the quantum caused. So when a controller sees
``/lockstep/settled`` T, every device sample and result stamped up to T is already in its queue, and
the requests it sends in its phase reach devices that are idle between two ticks: each decision and
each goal start happens at a defined cell time, not at whatever time a message happened to arrive.

What "sent everything" means for an rclpy node is ``drain``: run every ready callback and every task
that completes (an action result is sent by a task a few executor passes after the tick that ended
the goal) until a pass does nothing more. ``Participant.spin`` is the loop that drains before
answering; ``run_node`` uses it for a node that has a participant.
"""

from __future__ import annotations

import threading
import time
from typing import Callable, Protocol

import rclpy
from rclpy.clock import Clock as RclClock
from rclpy.clock import ClockType, ROSClock
from rclpy.duration import Duration
from rclpy.executors import Executor, TimeoutException
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from rclpy.timer import Timer
from std_msgs.msg import Header

__all__ = [
    "Hub",
    "host_in_process",
    "ROLES",
    "ANNOUNCE_TOPIC",
    "ANSWER_TOPIC",
    "LEAVE_SEC",
    "LOCKSTEP_QOS",
    "NANOSECONDS",
    "Participant",
    "drain",
    "run_tasks",
]

ROLES = ("tick", "react", "observe")
ANNOUNCE_TOPIC = {"tick": "/lockstep/tick", "react": "/lockstep/settled", "observe": "/lockstep/quiet"}
ANSWER_TOPIC = {"tick": "/lockstep/ticked", "react": "/lockstep/reacted", "observe": "/lockstep/observed"}
LEAVE_SEC = -1
# Wall seconds between a holding thread's looks at its stop request while it waits for an announcement.
STOP_LOOK_S = 0.05
# Reliable and deep: an answer lost or overwritten would hold the whole cell until the timeout.
LOCKSTEP_QOS = QoSProfile(
    depth=100,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
# Passes of a drain before it gives up looking for the end of a chain of tasks (a bound, never reached
# by the nodes here: a goal's result takes three).
MAX_DRAIN_PASSES = 50
JOIN_PERIOD_S = 0.25  # wall s between join messages until the first announcement
# The most an answer waits (wall s) for the readers of a delivered publisher (``Participant.delivered``) to
# acknowledge what it sent: a reader that never acknowledges (a stopped process) costs this once per sample.
DELIVERY_S = 2.0
ACK_LOOK_S = 0.0005  # wall s between looks at the acknowledgements (a reader's takes about 5 ms)
NANOSECONDS = 1_000_000_000
RCLError = rclpy_implementation.RCLError


class Hub(Protocol):
    """What runs the lockstep for the participants built in its own process (the hosted cell clock)."""

    def join(self, participant: Participant) -> None:
        """Take ``participant`` in: it is announced its role's phases by ``Participant.arrive``."""

    def answer(self, participant: Participant, now_ns: int, leave: bool) -> None:
        """Take ``participant``'s answer: done with ``now_ns`` (0 joins), or leaving."""


_HUB: list[Hub] = []  # the hub of this process, if a host installed one


def host_in_process(hub: Hub | None) -> None:
    """Install ``hub`` for the participants built from now on in this process (None: over DDS again)."""
    _HUB.clear()
    if hub is not None:
        _HUB.append(hub)


def drain(executor: Executor, tasks_only: bool = False, nodes: list[Node] | None = None) -> None:
    """Run every ready callback and every task that can finish, until one pass makes no progress.

    ``tasks_only``: nothing to do unless the executor has tasks (a tick participant: what its tick publishes
    is sent at once; only a goal's coroutine sends later, and a request that arrives may wait for the next
    turn). A pass asks the executor for ready work without waiting. A subscription, service or timer callback
    is progress, and so is a task that completes (a done callback, an action server's result); a coroutine
    task that is resumed and suspends again on a future not yet done is not (rclpy resumes every pending
    coroutine on every pass), so the drain ends while a goal waits for its next tick.

    ``nodes``: only these nodes' entities (the cell host drains its controller's, not every hosted node's).
    """
    for _ in range(MAX_DRAIN_PASSES):
        if tasks_only and not executor._tasks:
            return
        progressed = False
        while True:
            try:
                handler, entity, _node = executor.wait_for_ready_callbacks(timeout_sec=0, nodes=nodes)
            except TimeoutException:
                break
            handler()
            error = handler.exception()
            if error is not None:
                raise error
            if entity is not None or handler.done():
                progressed = True
        if not progressed:
            return


def run_tasks(executor: Executor) -> None:
    """Run the executor's tasks until a pass completes none: what a tick caused, with no wait set built.

    The cell host's drain after its devices' ticks. What a hosted tick publishes is sent at once; only a
    goal's coroutine, resumed by the tick, and the tasks it completes in turn (an action's result, a done
    callback) send later, and none of them waits for an entity. Building the wait set of every hosted node
    for that (``drain``) cost the host most of its time (3.5 ms a pass, profiled).
    """
    for _ in range(MAX_DRAIN_PASSES):
        with executor._tasks_lock:
            tasks = [task for task, _, _ in executor._tasks if not task.done() and not task.executing()]
        progressed = False
        for task in tasks:
            task()
            error = task.exception()
            if error is not None:
                raise error
            progressed = progressed or task.done()
        if not progressed:
            return


def _acknowledged(publisher: Publisher, timeout_s: float) -> bool:
    """Whether every reader acknowledges what ``publisher`` sent, within ``timeout_s`` (wall s).

    Looked at without blocking, every ACK_LOOK_S: rclpy's blocking ``wait_for_all_acked`` keeps the GIL,
    which would hold every other thread of the process (the cell host's executor) for the whole wait.
    """
    deadline = time.monotonic() + timeout_s
    while not publisher.wait_for_all_acked(Duration(nanoseconds=0)):
        if time.monotonic() > deadline:
            return False
        time.sleep(ACK_LOOK_S)
    return True


def _nanoseconds(msg: Header) -> int:
    return int(msg.stamp.sec) * NANOSECONDS + int(msg.stamp.nanosec)


class Participant:
    """One node's part in the lockstep: hear the role's announcements, answer once the work is sent.

    ``on_announce(T)`` (optional) runs in the announcement's callback, the node clock already at T: a tick
    participant simulates up to T there. The answer goes out from ``spin`` (or ``answer_pending``) after a
    drain, never from the callback, so everything the work caused has been sent before it. A react participant
    whose decisions run on another thread (the reference controller's cycle) sets ``hold`` and answers from
    that thread with ``release`` once its requests are answered (``wait_announcement`` waits for the next T).
    """

    def __init__(
        self,
        node: Node,
        role: str,
        on_announce: Callable[[int], None] | None = None,
        *,
        hold: bool = False,
    ) -> None:
        if role not in ROLES:
            raise ValueError(f"lockstep role must be one of {', '.join(ROLES)}, got {role!r}")
        self.node = node
        self.role = role
        # The node's fully qualified name without its leading slash: a Header's frame_id never has one.
        self.name = node.get_fully_qualified_name().lstrip("/")
        self.on_announce = on_announce
        self.hold = hold
        # Called once, after the node clock is set by the first announcement (and before its work): what
        # a node publishes at start-up waits for it, or its stamp would depend on when the clock came.
        self.on_first: Callable[[], None] | None = None
        self.announced_ns = -1  # the last T announced to this role
        self.answered_ns = -1  # the last T answered
        self.pending = False  # announced, not yet answered
        self._announced = threading.Condition()
        self.drained_ns = -1  # the last T after which the spinning thread drained (``hold`` mode)
        self.rewinds = 0  # times the clock was set back (``rewind``)
        self._joining: Timer | None = None
        self._undelivered: set[Publisher] = set()  # published since the last answer (``delivered``)
        # Two threads answer: the holding thread (``release``) and the executor's (the join timer, a
        # re-answer). One delivery wait at a time, so that neither answers while the other still waits.
        self._delivering = threading.Lock()
        self.hub: Hub | None = _HUB[0] if _HUB else None
        if self.hub is not None:
            self.hub.join(self)  # hosted: announced and answered by direct calls, nothing on DDS
            return
        self._answer = node.create_publisher(Header, ANSWER_TOPIC[role], LOCKSTEP_QOS)
        node.create_subscription(Header, ANNOUNCE_TOPIC[role], self._on_message, LOCKSTEP_QOS)
        # Join, and again until the first announcement comes: a message sent before the clock's reader
        # has matched this writer is lost (volatile), and react and observe announcements start only
        # once every expected participant has joined.
        self.send(0)
        self._joining = node.create_timer(
            JOIN_PERIOD_S, lambda: self.send(0), clock=RclClock(clock_type=ClockType.STEADY_TIME)
        )

    def _on_message(self, msg: Header) -> None:
        if self._joining is not None:
            self.node.destroy_timer(self._joining)
            self._joining = None
        now_ns = _nanoseconds(msg)
        if now_ns == self.answered_ns and not self.pending:
            # Heard again (the clock re-announces a phase it still waits for): answer again. DDS matches
            # the two ends of a topic each on its own, so an answer sent before the clock's reader had
            # matched this writer was lost; the first one, at start-up, was a join that never came.
            self.send(self.answered_ns)
            return
        self.arrive(now_ns)

    def arrive(self, now_ns: int) -> None:
        """Take the announcement of ``now_ns`` (from DDS, or by a direct call from the hub).

        A time earlier than the last announced is a rewind (the clock set back to its start: a
        ResetSimulation of time): the node clock jumps back with it and the participant starts again there.
        """
        clock = self.node.get_clock()
        rewound = 0 <= now_ns < self.announced_ns
        if (
            isinstance(clock, ROSClock)
            and clock.ros_time_is_active
            and (now_ns > clock.now().nanoseconds or rewound)
        ):
            # What rclpy's time source does with a /clock message (jump callbacks included): the node
            # clock reads T before the phase's work, whenever the coarse /clock last came.
            clock.set_ros_time_override(Time(nanoseconds=now_ns, clock_type=ClockType.ROS_TIME))
        if rewound:
            self.rewind(now_ns)
        self.announce(now_ns)

    def rewind(self, now_ns: int) -> None:
        """Forget every time after ``now_ns``: the next announcement of ``now_ns`` is new work.

        The clock sets cell time back only while every participant has answered its present quantum, so
        nothing is pending. A holding participant's thread must notice the rewind itself (``rewinds``):
        ``wait_announcement`` waits for a time after the one it names.
        """
        self.announced_ns = now_ns - 1  # not -1: what runs at the first announcement ran once already
        self.answered_ns = -1
        self.pending = False
        with self._announced:
            self.drained_ns = -1
            self.rewinds += 1
            self._announced.notify_all()

    def announce(self, now_ns: int) -> None:
        """Take in the announcement of ``now_ns``: do the role's work now, answer after the next drain."""
        if now_ns <= self.announced_ns:
            return
        first = self.announced_ns < 0
        self.announced_ns = now_ns
        if first and self.on_first is not None:
            self.on_first()
        if self.on_announce is not None:
            self.on_announce(now_ns)
        self.pending = True

    def answer_pending(self, executor: Executor, drained: bool = False) -> None:
        """Drain, then answer the pending announcement (or, holding, tell the holding thread it may look).

        ``drained``: the caller has drained already (the cell host drains once for all its participants).
        """
        if not self.pending:
            return
        if not drained:
            drain(executor, tasks_only=self.role == "tick")
        self.pending = False
        if self.hold:
            with self._announced:
                self.drained_ns = self.announced_ns
                self._announced.notify_all()
        else:
            self.send(self.announced_ns)

    def delivered(self, publisher: Publisher) -> None:
        """Make the next answer wait until every reader has acknowledged what ``publisher`` has sent.

        For a reliable publisher of news a reader must take in the quantum it was published in (a status
        published on change). Answering only says the samples were written: DDS orders what one writer
        sends, not what two writers of one process send to a third, so the clock's next announcement
        (another writer's) could reach the recorder first. An acknowledgement says the sample is in the
        reader's history. (It did not end the hosted controller's status logged a quantum late: there the
        recorder had it and did not take it; see ``lockstep_observer``.) Bounded by DELIVERY_S, with a
        warning naming the topic.
        """
        self._undelivered.add(publisher)

    def _deliver(self) -> None:
        # Under the lock: a thread that found the set emptied by the other must wait for that wait to end.
        # (CI: the join timer took the status, and the holding thread's answer went out at once.)
        with self._delivering:
            while self._undelivered:
                publisher = self._undelivered.pop()
                if not _acknowledged(publisher, DELIVERY_S):
                    self.node.get_logger().warning(
                        f"lockstep: not every reader of {publisher.topic_name} acknowledged it within "
                        f"{DELIVERY_S:g} s; answering all the same"
                    )

    def send(self, now_ns: int) -> None:
        """Publish an answer: done with ``now_ns`` (0 joins; ``leave`` leaves)."""
        self._deliver()
        if self.hub is not None:
            self.answered_ns = max(self.answered_ns, now_ns)
            self.hub.answer(self, now_ns, False)
            return
        header = Header(frame_id=self.name)
        header.stamp.sec, header.stamp.nanosec = divmod(now_ns, NANOSECONDS)
        self._answer.publish(header)
        self.answered_ns = max(self.answered_ns, now_ns)

    def leave(self) -> None:
        """Leave the lockstep: the clock stops waiting for this node (nothing to say once shut down)."""
        if self.hub is not None:
            self.hub.answer(self, -1, True)
            return
        if not self.node.context.ok():
            return
        header = Header(frame_id=self.name)
        header.stamp.sec = LEAVE_SEC
        try:
            self._answer.publish(header)
        except RCLError:
            pass  # the context ended between the check and the publish: the clock's timeout drops it

    # --- a holding participant (its decisions run on another thread) ----------------------------
    def wait_announcement(
        self, after_ns: int, timeout_s: float, stopped: Callable[[], bool] = lambda: False
    ) -> int:
        """Block until an announcement later than ``after_ns`` has been drained; return it (-1: timeout).

        Also -1 as soon as ``stopped()`` (looked at every STOP_LOOK_S): a stop request must not wait out
        the clock's silence, which a stopping cell makes likely.
        """
        deadline = time.monotonic() + timeout_s
        with self._announced:
            while self.drained_ns <= after_ns and not stopped():
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                self._announced.wait(min(remaining, STOP_LOOK_S))
            return self.drained_ns if self.drained_ns > after_ns else -1

    def release(self, now_ns: int) -> None:
        """Answer ``now_ns`` from the holding thread: its decisions for that time are sent and answered."""
        if now_ns > self.answered_ns:
            self.send(now_ns)

    # --- the spin loop --------------------------------------------------------------------------
    def spin(
        self, executor: Executor, poll_s: float = 0.1, stopped: Callable[[], bool] = lambda: False
    ) -> None:
        """Spin the executor, draining and answering after every callback that announced a time.

        Ends when the context shuts down or ``stopped()`` (looked at every ``poll_s`` at the latest).
        """
        while rclpy.ok(context=self.node.context) and not stopped():
            executor.spin_once(timeout_sec=poll_s)
            self.answer_pending(executor)
