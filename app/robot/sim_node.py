"""`tandem robot sim`: a ROS 1 node serving Baxter's interface on a simulated body.

What it serves (the topics and actions of Baxter's own robot, with the message
definitions Rethink published, so a setup is checked end to end without it):

- `/robot/joint_states` (sensor_msgs/JointState): the 14 arm joints
  (`left_s0` ... `right_w2`) and the 4 finger joints, with position, velocity
  and effort (the gravity torques where the arm is), at `rate` Hz;
- `/robot/limb/<side>/endpoint_state` (baxter_core_msgs/EndpointState): the
  gripper's endpoint pose and twist in the base frame (forward kinematics of
  the URDF), wrench zero, at `rate` Hz;
- `/robot/state` (AssemblyState) with `/robot/set_super_enable`, `_stop` and
  `_reset`; the grippers' `state`, `properties` and `command` (electric by
  default, or suction per side); the e-stop and stall drills on
  `/tandem_sim/estop` and `/tandem_sim/stall`: see `app.robot.sim_topics`;
- `/robot/limb/<side>/follow_joint_trajectory`
  (control_msgs/FollowJointTrajectoryAction): the trajectory is followed along
  the real server's cubic Bézier spline through its waypoints at their
  `time_from_start` (from its header's stamp when that is in the future), with
  the real server's tolerances, goal time and goal check, and its behaviour on a
  disabled or stopped robot (`app.robot.sim_follow`: such a goal SUCCEEDS
  without arriving unless it carries goal tolerances). Beyond the real server,
  a goal is aborted before moving (INVALID_JOINTS, or INVALID_GOAL with the
  joint named) when it names joints not of that arm, or its waypoints break the
  URDF's position or velocity limits (the allowances are in
  `app.robot.sim_model`); the spline is held within the position limits. A
  cancel, or a newer goal, stops the arm where it is within one tick
  (preempted).

Faults for tests, on `/tandem_sim/fault` (std_msgs/String): "abort" aborts the
running goals halfway through (PATH_TOLERANCE_VIOLATED; at once when past their
half), or when none runs the next one (halfway, whenever the fault arrives: the
arm has always left its start); "hang" makes the next goal hang, as a stuck
driver's would (accepted, never moved, never ended until it is cancelled);
"mute" stops publishing joint states, "unmute" resumes them.

The node sets the parameter `/rethink/software_version` (1.2.0) as Baxter does,
prints `simulated Baxter ready on <master>` once it has received its own first
joint state through the master (the graph works end to end), and exits with 0
on SIGINT or SIGTERM, stopping any motion.
"""

from __future__ import annotations

import importlib
import os
import signal
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import FrameType
from typing import Any
from urllib.parse import urlparse

from app.robot.ros_env import master_answers, use_ros
from app.robot.sim_follow import (
    Tolerances,
    goal_error,
    path_error,
    stall,
    stalled_joint,
    tolerances,
)
from app.robot.sim_gripper import GripperKind
from app.robot.sim_model import SIDES, BaxterModel, Motion, Rejection, Side, check_motion
from app.robot.sim_robot_state import RobotState
from app.robot.sim_topics import PROPERTIES_HZ, STATE_HZ, RobotTopics

NODE_NAME = "tandem_sim_baxter"
SOFTWARE_VERSION = "1.2.0"  # the robot software baxter_interface 1.2.0 checks for
READY_TIMEOUT_S = 30.0
# control_msgs/FollowJointTrajectoryResult's error codes.
ERROR_CODES = {
    "INVALID_GOAL": -1,
    "INVALID_JOINTS": -2,
    "PATH_TOLERANCE_VIOLATED": -4,
    "GOAL_TOLERANCE_VIOLATED": -5,
}


class NoMaster(RuntimeError):
    """No ROS master answers at the URI the node was given."""


@dataclass(frozen=True)
class SimSettings:
    master: str
    rate: float = 100.0  # joint states per second, and trajectory ticks
    start: Mapping[str, float] | None = None  # None: Baxter's home pose (the plan's start)
    gui: bool = False  # pybullet's window
    enabled: bool = True  # enabled at start (as after Rethink's enable_robot.py -e)
    grippers: Mapping[Side, GripperKind] = field(
        default_factory=lambda: {"left": "electric", "right": "electric"}
    )


class SimNode:
    """The node's ROS side: its publishers, subscribers and two action servers."""

    def __init__(
        self, settings: SimSettings, model: BaxterModel, robot: RobotState, stop: threading.Event
    ) -> None:
        self.settings = settings
        self.model = model
        self.robot = robot
        self.topics = RobotTopics(robot, model.grippers)
        self.stop = stop
        self.tick_s = 1.0 / settings.rate
        self.muted = False
        self._published = 0  # joint states sent
        self.abort_next = False
        self.hang_next = False
        self._abort_running = threading.Event()
        self._abort_taken = False  # a running goal was aborted by `_abort_running`
        self._running = 0  # goals being followed
        self._lock = threading.Lock()
        self.ros: dict[str, Any] = {}
        self._servers: dict[Side, Any] = {}
        self._endpoints: dict[Side, Any] = {}
        self._echo = threading.Event()  # our own first joint state came back

    def connect(self) -> None:
        rospy = importlib.import_module("rospy")
        actionlib = importlib.import_module("actionlib")
        self.ros = {
            "rospy": rospy,
            "sensor": importlib.import_module("sensor_msgs.msg"),
            "std": importlib.import_module("std_msgs.msg"),
            "control": importlib.import_module("control_msgs.msg"),
            "baxter": importlib.import_module("baxter_core_msgs.msg"),
        }
        rospy.init_node(NODE_NAME, argv=[NODE_NAME], disable_signals=True)
        rospy.set_param("/rethink/software_version", SOFTWARE_VERSION)
        sensor, std, baxter = self.ros["sensor"], self.ros["std"], self.ros["baxter"]
        self._joints = rospy.Publisher("/robot/joint_states", sensor.JointState, queue_size=10)
        self._echo_sub = rospy.Subscriber(
            "/robot/joint_states", sensor.JointState, lambda _: self._echo.set(), queue_size=1
        )
        rospy.Subscriber("/tandem_sim/fault", std.String, self._on_fault, queue_size=10)
        self.topics.connect()
        for side in SIDES:
            self._endpoints[side] = rospy.Publisher(
                f"/robot/limb/{side}/endpoint_state", baxter.EndpointState, queue_size=10
            )
            server = actionlib.SimpleActionServer(
                f"/robot/limb/{side}/follow_joint_trajectory",
                self.ros["control"].FollowJointTrajectoryAction,
                execute_cb=lambda goal, s=side: self._follow(s, goal),
                auto_start=False,
            )
            server.start()
            self._servers[side] = server

    def wait_idle(self, timeout_s: float) -> None:
        """Waits until no goal is being followed (or `timeout_s` passed)."""
        deadline = time.monotonic() + timeout_s
        while self._running and time.monotonic() < deadline:
            time.sleep(self.tick_s)

    # -- the publish loop ------------------------------------------------------------

    def run(self) -> None:
        """Publishes until `stop`; prints the ready line once our first state came back."""
        state_every = max(1, round(self.settings.rate / STATE_HZ))
        properties_every = max(1, round(self.settings.rate / PROPERTIES_HZ))
        began = next_tick = time.monotonic()
        ticks = 0
        ready = False
        while not self.stop.is_set():
            self.model.step_grippers(self.tick_s)
            if not self.muted:
                self._publish_joints()
            if ticks % state_every == 0:
                self.topics.publish_state()
            if ticks % properties_every == 0:
                self.topics.publish_properties()
            ticks += 1
            if not ready and self._echo.is_set():
                ready = True
                self._echo_sub.unregister()
                print(f"simulated Baxter ready on {self.settings.master}", flush=True)
            if not ready and time.monotonic() - began > READY_TIMEOUT_S:
                raise NoMaster("the node's own joint states never came back through the master")
            next_tick += self.tick_s
            delay = next_tick - time.monotonic()
            if delay > 0:
                self.stop.wait(delay)
            elif delay < -self.tick_s:  # fell behind (a busy machine): no burst to catch up
                next_tick = time.monotonic()

    def _publish_joints(self) -> None:
        rospy, sensor = self.ros["rospy"], self.ros["sensor"]
        positions, velocities, moved_at = self.model.reading()
        efforts = self.model.efforts()
        message = sensor.JointState(
            name=list(positions),
            position=list(positions.values()),
            velocity=[velocities[n] for n in positions],
            effort=[efforts[n] for n in positions],
        )
        message.header.stamp = rospy.Time.from_sec(moved_at) if moved_at else rospy.Time.now()
        self._joints.publish(message)
        self._published += 1
        self._publish_endpoints(message.header.stamp)

    def _publish_endpoints(self, stamp: Any) -> None:
        baxter = self.ros["baxter"]
        for side in SIDES:
            end = self.model.endpoint(side)
            message = baxter.EndpointState()
            message.header.stamp = stamp
            message.header.frame_id = "base"
            pose, twist = message.pose, message.twist
            pose.position.x, pose.position.y, pose.position.z = end.position
            o = pose.orientation
            o.x, o.y, o.z, o.w = end.orientation
            twist.linear.x, twist.linear.y, twist.linear.z = end.linear
            twist.angular.x, twist.angular.y, twist.angular.z = end.angular
            self._endpoints[side].publish(message)

    # -- subscribers -------------------------------------------------------------------

    def _on_fault(self, message: Any) -> None:
        fault = str(message.data).strip()
        if fault == "abort":
            with self._lock:
                if self._running:
                    self._abort_running.set()
                else:
                    self.abort_next = True
        elif fault == "hang":
            self.hang_next = True
        elif fault in ("mute", "unmute"):
            self.muted = fault == "mute"
        else:
            self.ros["rospy"].logwarn("unknown fault %r: abort, hang, mute or unmute", fault)

    # -- following a trajectory ----------------------------------------------------------

    def _follow(self, side: Side, goal: Any) -> None:
        server = self._servers[side]
        with self._lock:
            hang, self.hang_next = self.hang_next, False
        if hang:
            while not self.stop.is_set() and not server.is_preempt_requested():
                self.stop.wait(self.tick_s)
            server.set_preempted(self._result(None, "hung, then cancelled"), "hung")
            return
        trajectory = goal.trajectory
        motion = check_motion(
            side,
            list(trajectory.joint_names),
            [p.time_from_start.to_sec() for p in trajectory.points],
            [tuple(p.positions) for p in trajectory.points],
            self.model.positions(),
            self.model.limits,
        )
        if isinstance(motion, Rejection):
            server.set_aborted(self._result(motion.code, motion.text), motion.text)
            return
        limits = tolerances(
            motion.joints,
            [(t.name, t.position) for t in goal.path_tolerance],
            [(t.name, t.position) for t in goal.goal_tolerance],
            goal.goal_time_tolerance.to_sec(),
        )
        with self._lock:
            self._running += 1
            abort_at = motion.seconds / 2 if self.abort_next else None
            self.abort_next = False
        try:
            self._move(side, Following(motion, limits, self._start_delay(trajectory), abort_at))
        finally:
            with self._lock:
                self._running -= 1
                if not self._running:
                    # A fault that came as the last goal ended (its result already
                    # sent) is for the next goal.
                    if self._abort_running.is_set() and not self._abort_taken:
                        self.abort_next = True
                    self._abort_running.clear()
                    self._abort_taken = False

    def _start_delay(self, trajectory: Any) -> float:
        """Seconds until the trajectory's header stamp (0 when it is 0 or past)."""
        stamp = trajectory.header.stamp.to_sec()
        return max(0.0, stamp - self.ros["rospy"].Time.now().to_sec()) if stamp else 0.0

    def _move(self, side: Side, following: Following) -> None:
        """Commands the spline, then the last point for the goal time, while the
        robot lets the arm move; then checks the goal."""
        server, motion = self._servers[side], following.motion
        began = time.monotonic() + following.delay
        now = self.model.positions()
        start = {name: now[name] for name in motion.joints}
        short = self.topics.stall_rad
        stalled = stalled_joint(start, motion.last) if short > 0.0 else None
        end = motion.seconds + following.limits.goal_time
        last_t: float | None = None  # when the arm was last commanded
        while True:
            t, at = time.monotonic() - began, time.time()  # the same moment on both clocks
            if self._interrupted(server, motion, t, following.abort_at):
                return
            if t >= 0.0 and (t >= end or not self.robot.moving_allowed()):
                break
            if t >= 0.0:
                command, velocity = self._command(motion, t, start, stalled, short)
                # The arm is measured against the path where it was last commanded: a
                # late tick of this process (a loaded machine) is not the arm's error; a
                # stall is. The first tick measures the start against the path's.
                path = command
                if last_t is not None:
                    path = self._command(motion, last_t, start, None, 0.0)[0]
                off = path_error(following.limits, self.model.positions(), path)
                if off is not None:
                    self._hold(motion)
                    text = f"{off[0]} was {off[1]:+.4f} rad off its path {t:.2f} s in"
                    server.set_aborted(self._result("PATH_TOLERANCE_VIOLATED", text), text)
                    return
                self.model.set(command, velocity, at)
                last_t = t
            self.stop.wait(self.tick_s)
        self._hold(motion)
        self._judge(server, motion, following.limits)

    def _command(
        self,
        motion: Motion,
        t: float,
        start: Mapping[str, float],
        stalled: str | None,
        short: float,
    ) -> tuple[dict[str, float], dict[str, float]]:
        """The point commanded `t` seconds in: the spline's, within the joints'
        limits, a stalled joint held back."""
        command, velocity = motion.at(t)
        for name, value in command.items():
            limit = self.model.limits[name]
            command[name] = min(max(value, limit.lower), limit.upper)
        if stalled is not None:
            held = stall(command[stalled], start[stalled], motion.last[stalled], short)
            if held != command[stalled]:
                command[stalled], velocity[stalled] = held, 0.0
        return command, velocity

    def _interrupted(self, server: Any, motion: Motion, t: float, abort_at: float | None) -> bool:
        """Ends the goal on a cancel, a newer goal, the node stopping or an injected
        abort; whether it did."""
        if self.stop.is_set() or server.is_preempt_requested():
            self._hold(motion)
            text = f"stopped {max(t, 0.0):.2f} s into {motion.seconds:.2f} s"
            server.set_preempted(self._result(None, text), text)
            return True
        running_abort = self._abort_running.is_set() and t >= motion.seconds / 2
        if running_abort or (abort_at is not None and t >= abort_at):
            with self._lock:
                self._abort_taken = self._abort_taken or self._abort_running.is_set()
            self._hold(motion)
            text = f"fault injected: aborted {max(t, 0.0):.2f} s into {motion.seconds:.2f} s"
            server.set_aborted(self._result("PATH_TOLERANCE_VIOLATED", text), text)
            return True
        return False

    def _judge(self, server: Any, motion: Motion, limits: Tolerances) -> None:
        """The goal check at the end: succeeded, or aborted with the joint named."""
        why = goal_error(limits, self.model.positions(), self.model.velocities(), motion.last)
        if why is not None:
            server.set_aborted(self._result("GOAL_TOLERANCE_VIOLATED", why), why)
            return
        text = f"reached the last of {len(motion.times) - 1} waypoints"
        if not self.robot.moving_allowed():
            text = "the robot is disabled or stopped: the arm halted where it was"
        server.set_succeeded(self._result(None, text), text)

    def _hold(self, motion: Motion) -> None:
        """The arm stays where it is (velocities 0), and the joint states say so."""
        now = self.model.positions()
        self.model.set({name: now[name] for name in motion.joints})
        self._shown()

    def _shown(self) -> None:
        """Waits until a joint state read after this moment went out, so a client that
        takes the robot's state when the result comes sees where the arm ended (two
        publishes: the one under way may have read the joints before)."""
        target = self._published + 2
        deadline = time.monotonic() + 10 * self.tick_s
        while self._published < target and not self.muted and time.monotonic() < deadline:
            time.sleep(self.tick_s / 4)

    def _result(self, code: str | None, text: str) -> Any:
        result = self.ros["control"].FollowJointTrajectoryResult()
        result.error_code = ERROR_CODES[code] if code is not None else 0
        result.error_string = text
        return result


@dataclass(frozen=True)
class Following:
    """A goal being followed: its motion, tolerances, the wait before it starts (s),
    and when an injected abort ends it (s in; None: no abort)."""

    motion: Motion
    limits: Tolerances
    delay: float
    abort_at: float | None


def run_sim(settings: SimSettings) -> int:
    """Runs the node until SIGINT or SIGTERM; raises NoMaster when none answers."""
    use_ros()
    if not master_answers(settings.master, 2.0):
        raise NoMaster(f"no ROS master answers at {settings.master}")
    os.environ["ROS_MASTER_URI"] = settings.master
    host = urlparse(settings.master).hostname or ""
    if host in ("127.0.0.1", "localhost") and not (
        os.environ.get("ROS_HOSTNAME") or os.environ.get("ROS_IP")
    ):
        os.environ["ROS_HOSTNAME"] = "127.0.0.1"  # a local master: stay on loopback
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    model = BaxterModel(settings.start, settings.gui, settings.grippers)
    node = SimNode(settings, model, RobotState(settings.enabled), stop)
    try:
        node.connect()
        node.run()
    finally:
        stop.set()
        node.wait_idle(1.0)  # a running goal reports preempted while ROS still runs
        if node.ros:
            node.topics.close()
            node.ros["rospy"].signal_shutdown("stopped")
        model.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
