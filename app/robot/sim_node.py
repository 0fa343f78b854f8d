"""`tandem robot sim`: a ROS 1 node serving Baxter's interface on a simulated body.

What it serves (the topics and actions of Baxter's own robot, so a setup is
checked end to end without it):

- `/robot/joint_states` (sensor_msgs/JointState): the 14 arm joints
  (`left_s0` ... `right_w2`) and the 4 finger joints, at `rate` Hz;
- `/robot/limb/<side>/follow_joint_trajectory`
  (control_msgs/FollowJointTrajectoryAction): the trajectory is followed at its
  waypoints' `time_from_start` (from its header's stamp when that is in the
  future), interpolated at the publish rate, then succeeds. A goal is aborted
  before moving (INVALID_JOINTS, or INVALID_GOAL with the joint named) when it
  names joints not of that arm, or breaks the URDF's position or velocity limits
  (the allowances are in `app.robot.sim_model`). A cancel, or a newer goal,
  stops the arm where it is within one tick (preempted);
- `/robot/end_effector/<side>_gripper/command` (baxter_core_msgs/
  EndEffectorCommand, "grip" or "release") and `.../state` (EndEffectorState:
  position 0 closed - 100 open, gripping) at `GRIPPER_STATE_HZ`.

Faults for tests, on `/tandem_sim/fault` (std_msgs/String): "abort" aborts the
running goals (PATH_TOLERANCE_VIOLATED), or when none runs the next one halfway
through; "mute" stops publishing joint states, "unmute" resumes them.

The node prints `simulated Baxter ready on <master>` once it has received its
own first joint state through the master (the graph works end to end), and
exits with 0 on SIGINT or SIGTERM, stopping any motion.
"""

from __future__ import annotations

import importlib
import os
import signal
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from types import FrameType
from typing import Any
from urllib.parse import urlparse

from app.robot.ros_env import master_answers, use_ros
from app.robot.sim_model import (
    BaxterModel,
    Motion,
    Rejection,
    Side,
    check_motion,
)

NODE_NAME = "tandem_sim_baxter"
GRIPPER_STATE_HZ = 10.0
GRIPPER_ID = 65538  # Baxter's electric gripper's hardware id
READY_TIMEOUT_S = 30.0
# control_msgs/FollowJointTrajectoryResult's error codes.
ERROR_CODES = {"INVALID_GOAL": -1, "INVALID_JOINTS": -2, "PATH_TOLERANCE_VIOLATED": -4}
SIDES: tuple[Side, Side] = ("left", "right")


class NoMaster(RuntimeError):
    """No ROS master answers at the URI the node was given."""


@dataclass(frozen=True)
class SimSettings:
    master: str
    rate: float = 100.0  # joint states per second, and trajectory ticks
    start: Mapping[str, float] | None = None  # None: Baxter's home pose (the plan's start)
    gui: bool = False  # pybullet's window


class SimNode:
    """The node's ROS side: its publishers, subscribers and two action servers."""

    def __init__(self, settings: SimSettings, model: BaxterModel, stop: threading.Event) -> None:
        self.settings = settings
        self.model = model
        self.stop = stop
        self.tick_s = 1.0 / settings.rate
        self.muted = False
        self._published = 0  # joint states sent
        self.abort_next = False
        self._abort_running = threading.Event()
        self._running = 0  # goals being followed
        self._lock = threading.Lock()
        self.ros: dict[str, Any] = {}
        self._servers: dict[Side, Any] = {}
        self._gripper_states: dict[Side, Any] = {}
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
        sensor, std, baxter = self.ros["sensor"], self.ros["std"], self.ros["baxter"]
        self._joints = rospy.Publisher("/robot/joint_states", sensor.JointState, queue_size=10)
        self._echo_sub = rospy.Subscriber(
            "/robot/joint_states", sensor.JointState, lambda _: self._echo.set(), queue_size=1
        )
        rospy.Subscriber("/tandem_sim/fault", std.String, self._on_fault, queue_size=10)
        for side in SIDES:
            prefix = f"/robot/end_effector/{side}_gripper"
            self._gripper_states[side] = rospy.Publisher(
                f"{prefix}/state", baxter.EndEffectorState, queue_size=2
            )
            rospy.Subscriber(
                f"{prefix}/command",
                baxter.EndEffectorCommand,
                lambda message, s=side: self._on_gripper(s, message),
                queue_size=10,
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
        gripper_every = max(1, round(self.settings.rate / GRIPPER_STATE_HZ))
        began = next_tick = time.monotonic()
        ticks = 0
        ready = False
        while not self.stop.is_set():
            self.model.step_grippers(self.tick_s)
            if not self.muted:
                self._publish_joints()
            if ticks % gripper_every == 0:
                self._publish_grippers()
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
        positions, velocities = self.model.positions(), self.model.velocities()
        message = sensor.JointState(
            name=list(positions),
            position=list(positions.values()),
            velocity=[velocities[n] for n in positions],
        )
        message.header.stamp = rospy.Time.now()
        self._joints.publish(message)
        self._published += 1

    def _publish_grippers(self) -> None:
        rospy, baxter = self.ros["rospy"], self.ros["baxter"]
        for side, gripper in self.model.grippers.items():
            self._gripper_states[side].publish(
                baxter.EndEffectorState(
                    timestamp=rospy.Time.now(),
                    id=GRIPPER_ID,
                    enabled=1,
                    calibrated=1,
                    ready=int(not gripper.moving),
                    moving=int(gripper.moving),
                    gripping=int(gripper.gripping),
                    position=gripper.position,
                    force=30.0 if gripper.gripping else 0.0,
                    state="{}",
                    command=gripper.command,
                    command_sender=gripper.sender,
                    command_sequence=gripper.sequence,
                )
            )

    # -- subscribers -------------------------------------------------------------------

    def _on_fault(self, message: Any) -> None:
        fault = str(message.data).strip()
        if fault == "abort":
            with self._lock:
                if self._running:
                    self._abort_running.set()
                else:
                    self.abort_next = True
        elif fault in ("mute", "unmute"):
            self.muted = fault == "mute"
        else:
            self.ros["rospy"].logwarn("unknown fault %r: abort, mute or unmute", fault)

    def _on_gripper(self, side: Side, message: Any) -> None:
        if message.command in ("grip", "release"):
            self.model.command_gripper(side, message.command, message.sender, message.sequence)
        else:
            self.ros["rospy"].logwarn("gripper command %r: only grip and release", message.command)

    # -- following a trajectory ----------------------------------------------------------

    def _follow(self, side: Side, goal: Any) -> None:
        server = self._servers[side]
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
        with self._lock:
            self._running += 1
            abort_at = motion.seconds / 2 if self.abort_next else None
            self.abort_next = False
        try:
            self._move(side, motion, self._start_delay(trajectory), abort_at)
        finally:
            with self._lock:
                self._running -= 1
                if not self._running:
                    self._abort_running.clear()

    def _start_delay(self, trajectory: Any) -> float:
        """Seconds until the trajectory's header stamp (0 when it is 0 or past)."""
        stamp = trajectory.header.stamp.to_sec()
        return max(0.0, stamp - self.ros["rospy"].Time.now().to_sec()) if stamp else 0.0

    def _move(self, side: Side, motion: Motion, delay: float, abort_at: float | None) -> None:
        server = self._servers[side]
        began = time.monotonic() + delay
        while True:
            t = time.monotonic() - began
            if self.stop.is_set() or server.is_preempt_requested():
                self._hold(motion)
                text = f"stopped {max(t, 0.0):.2f} s into {motion.seconds:.2f} s"
                server.set_preempted(self._result(None, text), text)
                return
            if self._abort_running.is_set() or (abort_at is not None and t >= abort_at):
                self._hold(motion)
                text = f"fault injected: aborted {max(t, 0.0):.2f} s into {motion.seconds:.2f} s"
                server.set_aborted(self._result("PATH_TOLERANCE_VIOLATED", text), text)
                return
            if t >= 0.0:
                self.model.set(
                    dict(zip(motion.joints, motion.at(t), strict=True)),
                    _velocity(motion, t),
                )
            if t >= motion.seconds:
                self._shown()
                text = f"reached the last of {len(motion.times) - 1} waypoints"
                server.set_succeeded(self._result(None, text), text)
                return
            self.stop.wait(self.tick_s)

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


def _velocity(motion: Motion, t: float) -> dict[str, float]:
    """The joints' velocities `t` seconds in (the segment's slope; 0 after the end)."""
    if t >= motion.seconds:
        return dict.fromkeys(motion.joints, 0.0)
    dt = 1e-3
    before, after = motion.at(max(t - dt, 0.0)), motion.at(t + dt)
    span = (t + dt) - max(t - dt, 0.0)
    return {n: (b - a) / span for n, a, b in zip(motion.joints, before, after, strict=True)}


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
    model = BaxterModel(settings.start, settings.gui)
    node = SimNode(settings, model, stop)
    try:
        node.connect()
        node.run()
    finally:
        stop.set()
        node.wait_idle(1.0)  # a running goal reports preempted while ROS still runs
        if node.ros:
            node.ros["rospy"].signal_shutdown("stopped")
        model.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
