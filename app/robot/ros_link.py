"""The robot link to ROS 1 as Baxter speaks it.

What it sends and reads (Baxter's own interface, which `tandem robot sim`
serves as well):

- `/robot/limb/<side>/follow_joint_trajectory`: a
  `control_msgs/FollowJointTrajectoryAction` goal per motion, the arm's seven
  joints with each waypoint's `time_from_start`, and the tolerances of
  `app.execution.robot_link` (each joint's goal and path tolerance, the goal
  time tolerance), so Rethink's server checks the arrival (by default it does
  not);
- `/robot/end_effector/<side>_gripper/...`: the grippers, driven as Rethink's
  Gripper drives them (`app.robot.link_gripper`) once a hold or an unhold
  reached its end;
- `/robot/state`: the robot's enable state (`app.robot.link_state`): a motion
  on a robot not enabled, or stopped, is refused; one that becomes so while a
  goal runs is a fault;
- `/robot/joint_states`: `sensor_msgs/JointState`, kept as the robot's state,
  streamed to watchers and sampled along each motion; a motion the robot says
  it finished counts only once a joint state published after it shows every
  joint within the goal tolerance.

Faults come back as `Followed` reports (or `RobotFault` from `connect`,
`check_ready` and `joints`): no master, no action server, a goal rejected,
aborted or preempted, a robot disabled or stopped, an arm off its goal, a
gripper that did not do its command, joint states silent for `SILENT_S`, the
master gone (asked every `MASTER_CHECK_S` while a goal runs: topics between
nodes outlive it).

The robot's clock need not agree with this machine's: its stamps are turned
into this machine's time by the smallest difference between a state's arrival
and its stamp over the last `LAG_WINDOW` states (the clock offset plus the
fastest delivery), so "published after the goal ended" means the same on both.

rospy is imported here only, and only when this link connects (`use_ros`).
"""

from __future__ import annotations

import importlib
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from app.execution.robot_link import (
    GOAL_TIME_TOLERANCE_S,
    GOAL_TOLERANCE_RAD,
    PATH_TOLERANCE_RAD,
    Followed,
    GripperCommand,
    JointListener,
    Joints,
    JointState,
    RobotFault,
    Side,
    Trajectory,
    off_goal,
)
from app.robot.link_gripper import Gripper
from app.robot.link_network import advertised_line, choose_address
from app.robot.link_state import StateWatch
from app.robot.ros_env import master_answers, use_ros

SILENT_S = 1.0  # no joint state for this long: the robot (or its driver) is gone
MASTER_CHECK_S = 0.5
CANCEL_WAIT_S = 0.4  # a cancelled goal reports preempted within this
# A goal with no result this long after its motion's end (and its goal time) has been
# lost on the way: the link cancels it and says so instead of waiting for ever.
RESULT_GRACE_S = 5.0
LOST = 9  # actionlib's GoalStatus.LOST: the client no longer hears of the goal
# /robot/state is a topic of its own: an e-stop that ends a goal may be said there a
# moment after the goal's result, so an arm short of its end waits this long for why.
STATE_LAG_S = 0.5
TICK_S = 0.02
LAG_WINDOW = 200  # joint states over which the robot's clock offset is taken
# actionlib's goal states (actionlib_msgs/GoalStatus).
# FollowJointTrajectoryResult's INVALID_GOAL and INVALID_JOINTS: a goal refused
# before the arm moved (Baxter's server aborts such goals rather than rejecting).
REFUSED_CODES = (-1, -2)
GOAL_TOLERANCE_VIOLATED = -5  # the server checked the arrival (our tolerances) and failed it
# The master this process's rospy node is on (rospy allows one per process, for good).
_NODE_MASTER: list[str] = []
_NODE_LOCK = threading.Lock()
_STATES = {2: "preempted", 3: "succeeded", 4: "aborted", 5: "rejected", 8: "preempted"}


class RosLink:
    """`RobotLink` over ROS 1 (see the module's text). `master_uri` None: the
    environment's `ROS_MASTER_URI`."""

    name = "ros"

    def __init__(self, master_uri: str | None = None, enable: bool = False) -> None:
        self.master_uri = master_uri or os.environ.get("ROS_MASTER_URI", "http://localhost:11311")
        self.enable = enable  # enable the robot when connecting (as RobotEnable.enable)
        self._lock = threading.Lock()
        self._state: JointState | None = None
        self._received = 0.0  # time.monotonic() of the last joint state
        self._lags: deque[float] = deque(maxlen=LAG_WINDOW)  # arrival - stamp (s)
        self._robot: StateWatch | None = None
        self._gripper: dict[str, Gripper] = {}
        self._watchers: list[JointListener] = []
        self._samples: list[tuple[float, JointState]] | None = None
        self._cancel = threading.Event()
        self._clients: dict[str, Any] = {}
        self._ros: dict[str, Any] = {}
        self._subscriber: Any = None

    # -- connecting ---------------------------------------------------------------

    def connect(self, timeout_s: float = 5.0) -> None:
        use_ros()
        if not self._master_alive():
            raise RobotFault("no-master", f"no ROS master answers at {self.master_uri}")
        rospy = importlib.import_module("rospy")
        actionlib = importlib.import_module("actionlib")
        control = importlib.import_module("control_msgs.msg")
        sensor = importlib.import_module("sensor_msgs.msg")
        baxter = importlib.import_module("baxter_core_msgs.msg")
        self._ros = {"rospy": rospy, "control": control, "baxter": baxter}
        self._init_node(rospy)
        self._subscriber = rospy.Subscriber(
            "/robot/joint_states", sensor.JointState, self._on_joints, queue_size=50
        )
        self._robot = StateWatch(rospy)
        sides: tuple[Side, Side] = ("left", "right")
        self._gripper = {side: Gripper(rospy, side) for side in sides}
        for side in sides:
            topic = f"/robot/limb/{side}/follow_joint_trajectory"
            client = actionlib.SimpleActionClient(topic, control.FollowJointTrajectoryAction)
            if not client.wait_for_server(rospy.Duration(timeout_s)):
                raise RobotFault("no-server", f"no trajectory action server at {topic}")
            self._clients[side] = client
        deadline = time.monotonic() + timeout_s
        while self._state is None and time.monotonic() < deadline:
            time.sleep(TICK_S)
        if self._state is None:
            raise RobotFault("silent", "the robot publishes no joint states on /robot/joint_states")
        self._robot.wait(max(deadline - time.monotonic(), 1.0))
        if self.enable:
            self._robot.enable()
        self._prepare_grippers(deadline)

    def _prepare_grippers(self, deadline: float) -> None:
        """Calibrates the electric grippers once, at the start, on a robot that can move
        them; an absent gripper faults only when a hold needs it."""
        for gripper in self._gripper.values():
            try:
                gripper.wait(max(deadline - time.monotonic(), 0.5))
            except RobotFault:
                continue
            if self._robot is not None and self._robot.fault() is None:
                gripper.prepare()

    def advertised(self) -> str:
        rospy = self._ros["rospy"]
        return advertised_line(rospy.get_node_uri() or "", self.master_uri, os.environ)

    def check_ready(self) -> None:
        fault = self._robot.fault() if self._robot is not None else None
        if fault is not None:
            raise RobotFault(fault.cause, fault.line, self._last())

    def _init_node(self, rospy: Any) -> None:
        """This process as a ROS node, once: rospy binds a process to one master."""
        with _NODE_LOCK:
            if not rospy.core.is_initialized():
                os.environ["ROS_MASTER_URI"] = self.master_uri
                choose_address(self.master_uri, os.environ)
                rospy.init_node("tandem_executor", anonymous=True, disable_signals=True)
                _NODE_MASTER.append(self.master_uri)
            # A node made elsewhere in this process took the environment's master.
            bound = _NODE_MASTER[0] if _NODE_MASTER else os.environ.get("ROS_MASTER_URI", "")
        if bound.rstrip("/") != self.master_uri.rstrip("/"):
            raise RobotFault(
                "no-master", f"this program already talks to the ROS master at {bound}: "
                f"restart it to use {self.master_uri}",
            )  # fmt: skip

    def _master_alive(self) -> bool:
        return master_answers(self.master_uri)

    # -- the robot's state ----------------------------------------------------------

    def _on_joints(self, message: Any) -> None:
        # The robot's own stamp, on this machine's clock (see the module's text): a state
        # handled late was still measured when stamped.
        arrived = time.time()
        stamp = message.header.stamp.to_sec() or arrived
        with self._lock:
            self._lags.append(arrived - stamp)
            state = JointState(
                stamp + min(self._lags), dict(zip(message.name, message.position, strict=False))
            )
            self._state = state
            self._received = time.monotonic()
            if self._samples is not None:
                self._samples.append((time.monotonic(), state))
            watchers = list(self._watchers)
        for watch in watchers:
            watch(state)

    def joints(self) -> Joints:
        with self._lock:
            state, received = self._state, self._received
        if state is None or time.monotonic() - received > SILENT_S:
            if not self._master_alive():
                raise RobotFault("master-lost", f"the ROS master at {self.master_uri} is gone")
            raise RobotFault("silent", f"no joint state for {SILENT_S:.0f} s: the robot is silent")
        return dict(state.positions)

    def watch(self, listener: JointListener) -> Callable[[], None]:
        with self._lock:
            self._watchers.append(listener)

        def stop() -> None:
            with self._lock:
                if listener in self._watchers:
                    self._watchers.remove(listener)

        return stop

    # -- moving -------------------------------------------------------------------------

    def follow(self, trajectory: Trajectory, gripper: GripperCommand | None) -> Followed:
        client = self._clients[trajectory.arm]
        # The samples' zero is taken before the goal is sent: the arm may move, and
        # states arrive, while send_goal is still returning on a loaded machine.
        began, began_wall = time.monotonic(), time.time()
        with self._lock:
            self._samples = []
        client.send_goal(self._goal(trajectory))
        try:
            cause, detail = self._wait(client, trajectory)
        except BaseException:  # Ctrl-C, SIGTERM: the arm must not go on alone
            client.cancel_goal()
            raise
        finally:
            self._cancel.clear()  # a cancel while no goal ran stops the next one at once
            with self._lock:
                samples, self._samples = self._samples or [], None
        if cause is None:
            self._fresh(time.time())  # where the arm stopped, not a tick before
            cause, detail = self._arrived(trajectory)
        last = self._last()
        if cause is None and gripper is not None:
            cause, detail = self._grip(trajectory.arm, gripper, detail)
        names = trajectory.joints
        kept = tuple(
            (round(t - began, 3), tuple(s.positions.get(j, float("nan")) for j in names))
            for t, s in samples
        )
        return Followed(cause, detail, last, kept, began_wall)

    def _last(self) -> Joints:
        with self._lock:
            return dict(self._state.positions) if self._state is not None else {}

    def _arrived(self, trajectory: Trajectory) -> tuple[Any, str]:
        """The goal succeeded: whether the robot is still enabled and the arm at its end
        (Rethink's server may say succeeded for an arm that never moved)."""
        done = f"reached the end of {len(trajectory.points)} waypoints"
        fault = self._robot.fault(during=True) if self._robot is not None else None
        if fault is not None:
            return fault.cause, fault.line
        off = off_goal(self._last(), trajectory.final())
        if off is None:
            return None, done
        fault = self._robot_fault_within(STATE_LAG_S)
        if fault is not None:
            return fault.cause, fault.line
        joint, error = off
        return "off-goal", (
            f"the {trajectory.arm} arm stopped {abs(error):.3f} rad from the end of its "
            f"motion at {joint} (tolerance {GOAL_TOLERANCE_RAD} rad), though the robot said "
            "it arrived"
        )

    def _robot_fault_within(self, timeout_s: float) -> RobotFault | None:
        """The robot's state fault, if its state says one within `timeout_s`."""
        deadline = time.monotonic() + timeout_s
        while self._robot is not None:
            fault = self._robot.fault(during=True)
            if fault is not None or time.monotonic() > deadline:
                return fault
            time.sleep(TICK_S)
        return None

    def _wait(self, client: Any, trajectory: Trajectory) -> tuple[Any, str]:
        """Waits for the goal's end, a cancel, a robot disabled or stopped, a silent
        robot or a lost master."""
        checked = time.monotonic()
        deadline = checked + trajectory.seconds + GOAL_TIME_TOLERANCE_S + RESULT_GRACE_S
        while True:
            fault = self._robot.fault(during=True) if self._robot is not None else None
            if fault is not None:
                client.cancel_goal()
                return fault.cause, fault.line
            status = int(client.get_state())
            if status == LOST or time.monotonic() > deadline:
                client.cancel_goal()
                return "no-result", self._no_result(status == LOST, trajectory)
            state = _STATES.get(status)
            if state == "succeeded":
                return None, f"reached the end of {len(trajectory.points)} waypoints"
            if state == "preempted" and not self._cancel.is_set():
                # Rethink's server preempts a goal itself when the robot is disabled.
                fault = self._robot_fault_within(CANCEL_WAIT_S)
                if fault is not None:
                    return fault.cause, fault.line
            if state is not None:
                # The status can come before the result that carries the robot's words.
                client.wait_for_result(self._ros["rospy"].Duration(CANCEL_WAIT_S))
                result = client.get_result()
                words = getattr(result, "error_string", "") if result is not None else ""
                code = getattr(result, "error_code", 0)
                if state == "aborted" and code in REFUSED_CODES:
                    state = "rejected"  # refused before moving, as Baxter's server does
                if state == "aborted" and code == GOAL_TOLERANCE_VIOLATED:
                    self._fresh(time.time())
                    cause, line = self._arrived(trajectory)  # the joint, as measured here
                    if cause is not None:
                        return cause, line
                return state, f"the {trajectory.arm} arm's goal was {state}" + (
                    f": {words}" if words else ""
                )
            if self._cancel.is_set():
                client.cancel_goal()
                client.wait_for_result(self._ros["rospy"].Duration(CANCEL_WAIT_S))
                return "preempted", f"the {trajectory.arm} arm's motion was stopped"
            now = time.monotonic()
            if now - self._received > SILENT_S:
                client.cancel_goal()
                cause = "silent" if self._master_alive() else "master-lost"
                return cause, f"no joint state for {SILENT_S:.0f} s during the motion"
            if now - checked > MASTER_CHECK_S:
                checked = now
                if not self._master_alive():
                    client.cancel_goal()
                    return "master-lost", f"the ROS master at {self.master_uri} is gone"
            time.sleep(TICK_S)

    def _no_result(self, lost: bool, trajectory: Trajectory) -> str:
        if lost:
            return f"the robot lost the {trajectory.arm} arm's goal: no result came for it"
        return (
            f"no result for the {trajectory.arm} arm's goal {RESULT_GRACE_S:.0f} s after "
            f"its motion's end ({trajectory.seconds:.1f} s): cancelled"
        )

    def _fresh(self, after: float) -> JointState | None:
        """The first joint state measured after `after` (this machine's epoch seconds; the
        robot's stamps turned to them): a tick or two, `SILENT_S` at most (None then);
        rospy's threads may hand over states late under load."""
        deadline = time.monotonic() + SILENT_S
        while time.monotonic() < deadline:
            with self._lock:
                state = self._state
            if state is not None and state.stamp > after:
                return state
            time.sleep(TICK_S / 4)
        return None

    def _goal(self, trajectory: Trajectory) -> Any:
        rospy, control = self._ros["rospy"], self._ros["control"]
        points = importlib.import_module("trajectory_msgs.msg")
        goal = control.FollowJointTrajectoryGoal()
        goal.trajectory.joint_names = list(trajectory.joints)
        for q, t in zip(trajectory.points, trajectory.times, strict=True):
            goal.trajectory.points.append(
                points.JointTrajectoryPoint(positions=list(q), time_from_start=rospy.Duration(t))
            )
        goal.trajectory.header.stamp = rospy.Time(0)  # start now
        for name in trajectory.joints:
            goal.goal_tolerance.append(
                control.JointTolerance(name=name, position=GOAL_TOLERANCE_RAD)
            )
            goal.path_tolerance.append(
                control.JointTolerance(name=name, position=PATH_TOLERANCE_RAD)
            )
        goal.goal_time_tolerance = rospy.Duration(GOAL_TIME_TOLERANCE_S)
        return goal

    def _grip(self, side: str, command: GripperCommand, detail: str) -> tuple[Any, str]:
        """The gripper's command after the motion: its fault, or the motion's `detail`."""
        try:
            self._gripper[side].do(command)
        except RobotFault as fault:
            return fault.cause, fault.line
        return None, detail

    def cancel(self) -> None:
        self._cancel.set()

    def close(self) -> None:
        with self._lock:
            self._watchers.clear()
        for client in self._clients.values():
            client.cancel_all_goals()
        for gripper in self._gripper.values():
            gripper.close()
        if self._robot is not None:
            self._robot.close()
        if self._subscriber is not None:
            self._subscriber.unregister()
            self._subscriber = None
