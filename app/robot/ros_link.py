"""The robot link to ROS 1 as Baxter speaks it.

What it sends and reads (Baxter's own interface, which `tandem robot sim`
serves as well):

- `/robot/limb/<side>/follow_joint_trajectory`: a
  `control_msgs/FollowJointTrajectoryAction` goal per motion, the arm's seven
  joints with each waypoint's `time_from_start`;
- `/robot/end_effector/<side>_gripper/command`: a
  `baxter_core_msgs/EndEffectorCommand` ("grip" or "release") once a hold or
  an unhold reached its end;
- `/robot/joint_states`: `sensor_msgs/JointState`, kept as the robot's state,
  streamed to watchers and sampled along each motion.

Faults come back as `Followed` reports (or `RobotFault` from `connect` and
`joints`): no master, no action server, a goal rejected, aborted or
preempted, joint states silent for `SILENT_S`, the master gone (asked every
`MASTER_CHECK_S` while a goal runs: topics between nodes outlive it).

rospy is imported here only, and only when this link connects (`use_ros`).
"""

from __future__ import annotations

import importlib
import os
import threading
import time
from collections.abc import Callable
from typing import Any

from app.execution.robot_link import (
    Followed,
    GripperCommand,
    JointListener,
    Joints,
    JointState,
    RobotFault,
    Trajectory,
)
from app.robot.ros_env import master_answers, use_ros

SILENT_S = 1.0  # no joint state for this long: the robot (or its driver) is gone
MASTER_CHECK_S = 0.5
CANCEL_WAIT_S = 0.4  # a cancelled goal reports preempted within this
TICK_S = 0.02
# Baxter's electric gripper's hardware id in EndEffectorCommand.
GRIPPER_ID = 65538
# actionlib's goal states (actionlib_msgs/GoalStatus).
# FollowJointTrajectoryResult's INVALID_GOAL and INVALID_JOINTS: a goal refused
# before the arm moved (Baxter's server aborts such goals rather than rejecting).
REFUSED_CODES = (-1, -2)
# The master this process's rospy node is on (rospy allows one per process, for good).
_NODE_MASTER: list[str] = []
_NODE_LOCK = threading.Lock()
_STATES = {2: "preempted", 3: "succeeded", 4: "aborted", 5: "rejected", 8: "preempted"}


class RosLink:
    """`RobotLink` over ROS 1 (see the module's text). `master_uri` None: the
    environment's `ROS_MASTER_URI`."""

    name = "ros"

    def __init__(self, master_uri: str | None = None) -> None:
        self.master_uri = master_uri or os.environ.get("ROS_MASTER_URI", "http://localhost:11311")
        self._lock = threading.Lock()
        self._state: JointState | None = None
        self._received = 0.0  # time.monotonic() of the last joint state
        self._watchers: list[JointListener] = []
        self._samples: list[tuple[float, JointState]] | None = None
        self._cancel = threading.Event()
        self._clients: dict[str, Any] = {}
        self._grippers: dict[str, Any] = {}
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
        for side in ("left", "right"):
            topic = f"/robot/limb/{side}/follow_joint_trajectory"
            client = actionlib.SimpleActionClient(topic, control.FollowJointTrajectoryAction)
            if not client.wait_for_server(rospy.Duration(timeout_s)):
                raise RobotFault("no-server", f"no trajectory action server at {topic}")
            self._clients[side] = client
            self._grippers[side] = rospy.Publisher(
                f"/robot/end_effector/{side}_gripper/command",
                baxter.EndEffectorCommand, queue_size=2,
            )  # fmt: skip
        deadline = time.monotonic() + timeout_s
        while self._state is None and time.monotonic() < deadline:
            time.sleep(TICK_S)
        if self._state is None:
            raise RobotFault("silent", "the robot publishes no joint states on /robot/joint_states")

    def _init_node(self, rospy: Any) -> None:
        """This process as a ROS node, once: rospy binds a process to one master."""
        with _NODE_LOCK:
            if not rospy.core.is_initialized():
                os.environ["ROS_MASTER_URI"] = self.master_uri
                os.environ.setdefault("ROS_HOSTNAME", "127.0.0.1")
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
        # The robot's own stamp: a state handled late was still measured when stamped.
        stamp = message.header.stamp.to_sec() or time.time()
        state = JointState(stamp, dict(zip(message.name, message.position, strict=False)))
        with self._lock:
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
        with self._lock:
            self._samples = []
        client.send_goal(self._goal(trajectory))
        began = time.monotonic()
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
        last = dict(self._state.positions) if self._state is not None else {}
        if cause is None and gripper is not None:
            self._grip(trajectory.arm, gripper)
        names = trajectory.joints
        kept = tuple(
            (round(t - began, 3), tuple(s.positions.get(j, float("nan")) for j in names))
            for t, s in samples
        )
        return Followed(cause, detail, last, kept)

    def _wait(self, client: Any, trajectory: Trajectory) -> tuple[Any, str]:
        """Waits for the goal's end, a cancel, a silent robot or a lost master."""
        checked = time.monotonic()
        while True:
            state = _STATES.get(int(client.get_state()))
            if state == "succeeded":
                return None, f"reached the end of {len(trajectory.points)} waypoints"
            if state is not None:
                # The status can come before the result that carries the robot's words.
                client.wait_for_result(self._ros["rospy"].Duration(CANCEL_WAIT_S))
                result = client.get_result()
                words = getattr(result, "error_string", "") if result is not None else ""
                if state == "aborted" and getattr(result, "error_code", 0) in REFUSED_CODES:
                    state = "rejected"  # refused before moving, as Baxter's server does
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

    def _fresh(self, after: float) -> None:
        """Waits for a joint state stamped after `after` (epoch seconds: a tick or two,
        `SILENT_S` at most); rospy's threads may hand over states late under load."""
        deadline = time.monotonic() + SILENT_S
        while time.monotonic() < deadline:
            with self._lock:
                state = self._state
            if state is not None and state.stamp > after:
                return
            time.sleep(TICK_S / 4)

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
        return goal

    def _grip(self, side: str, command: GripperCommand) -> None:
        message = self._ros["baxter"].EndEffectorCommand(
            id=GRIPPER_ID, command=command, args="{}", sender="tandem", sequence=0
        )
        self._grippers[side].publish(message)

    def cancel(self) -> None:
        self._cancel.set()

    def close(self) -> None:
        with self._lock:
            self._watchers.clear()
        for client in self._clients.values():
            client.cancel_all_goals()
        if self._subscriber is not None:
            self._subscriber.unregister()
            self._subscriber = None
