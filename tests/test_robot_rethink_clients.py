"""Clients that use Baxter's interface as Rethink's own client classes use it
(baxter_interface 1.2.0's RobotEnable, Limb and Gripper, and baxter_examples'
trajectory client), written here from the published message definitions and
the classes' documented behaviour, against `tandem robot sim`.

What each needs of the robot, and failed on the node before it served it:
- the enable client reads `/robot/state` within 2 s and the robot software
  version parameter, enables with `/robot/set_super_enable`, stops with
  `set_super_stop` and resets with `set_super_reset` (refusing while the e-stop
  button is pressed);
- the limb client reads every arm joint's position, velocity and effort
  (`msg.effort[idx]`) and waits for `/robot/limb/<side>/endpoint_state`;
- the gripper client waits 5 s for the gripper's state and properties, takes
  the id from the state and the type from the properties, configures its
  parameters, calibrates an electric gripper (after clearing its calibration
  and any error) and commands positions with `go`; a suction cup is closed with
  `go` and opened with `release`.

The node runs with Baxter booted disabled (`--enabled no`), an electric gripper
on the left and a suction cup on the right. The last test needs no robot: the
paths the planner checked, timed as the link times them, stay on what OMPL
checked when the server splines them.
"""

from __future__ import annotations

import importlib
import json
import math
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest

from app.execution.robot_drive import timed
from app.robot.sim_spline import BezierSpline
from planner.feasibility.arms import HOME, joint_names
from planner.feasibility.path_planner import RESOLUTION
from planner.feasibility.robot import baxter_urdf
from tests.plan_fixtures import default_plan
from tests.robot_graph import ROOT, ros_installed, ros_node, shared_master

SDK_VERSION = "1.2.0"
FIRMWARE_FAIL_BEFORE = "2013/10/15 00:00:00"  # baxter_interface 1.2.0's gripper check
SUCCEEDED = 3


def _wait(
    test: Callable[[], bool], timeout_s: float, body: Callable[[], Any] | None = None
) -> bool:
    """Rethink's `wait_for`: until `test`, calling `body` between tries."""
    deadline = time.monotonic() + timeout_s
    while not test():
        if time.monotonic() > deadline:
            return False
        if body is not None:
            body()
        time.sleep(0.02)
    return True


class EnableClient:
    """Robot state and enabling, as `RobotEnable` does it."""

    def __init__(self, rospy: Any) -> None:
        std = importlib.import_module("std_msgs.msg")
        self.baxter = importlib.import_module("baxter_core_msgs.msg")
        self.rospy, self.std = rospy, std
        self.state: Any = None
        self._sub = rospy.Subscriber("robot/state", self.baxter.AssemblyState, self._on_state)
        self._enable = rospy.Publisher("robot/set_super_enable", std.Bool, queue_size=10)
        self._stop = rospy.Publisher("robot/set_super_stop", std.Empty, queue_size=10)
        self._reset = rospy.Publisher("robot/set_super_reset", std.Empty, queue_size=10)
        assert _wait(lambda: self.state is not None, 2.0), "Failed to get robot state"

    def _on_state(self, message: Any) -> None:
        self.state = message

    def version_ok(self) -> bool:
        version = self.rospy.get_param("rethink/software_version", None)
        return isinstance(version, str) and version.startswith(SDK_VERSION)

    def enable(self) -> None:
        if self.state.stopped:
            self.reset()
        body = lambda: self._enable.publish(self.std.Bool(True))  # noqa: E731
        assert _wait(lambda: self.state.enabled, 2.0, body), "Failed to enable robot"

    def stop(self) -> None:
        body = lambda: self._stop.publish(self.std.Empty())  # noqa: E731
        assert _wait(lambda: self.state.stopped, 3.0, body), "Failed to stop the robot"

    def reset(self) -> None:
        s = self.state
        if s.stopped and s.estop_button == self.baxter.AssemblyState.ESTOP_BUTTON_PRESSED:
            raise OSError("Failed to Reset: E-Stop Engaged")

        def is_reset() -> bool:
            s = self.state
            return not (s.enabled or s.stopped or s.error or s.estop_button or s.estop_source)

        body = lambda: self._reset.publish(self.std.Empty())  # noqa: E731
        assert _wait(is_reset, 3.0, body), "Failed to reset robot"

    def close(self) -> None:
        self._sub.unregister()


class LimbClient:
    """One arm's joints and endpoint, as `Limb` reads them."""

    def __init__(self, rospy: Any, side: str) -> None:
        sensor = importlib.import_module("sensor_msgs.msg")
        baxter = importlib.import_module("baxter_core_msgs.msg")
        self.names = joint_names(side)
        self.angle: dict[str, float] = {}
        self.velocity: dict[str, float] = {}
        self.effort: dict[str, float] = {}
        self.pose: dict[str, tuple[float, ...]] = {}
        ns = f"/robot/limb/{side}/"
        self._subs = [
            rospy.Subscriber(ns + "endpoint_state", baxter.EndpointState, self._on_endpoint),
            rospy.Subscriber("robot/joint_states", sensor.JointState, self._on_joints),
        ]
        assert _wait(lambda: len(self.angle) > 0, 15.0), "failed to get current joint_states"
        assert _wait(lambda: len(self.pose) > 0, 15.0), "failed to get current endpoint_state"

    def _on_joints(self, message: Any) -> None:
        for idx, name in enumerate(message.name):
            if name in self.names:
                self.angle[name] = message.position[idx]
                self.velocity[name] = message.velocity[idx]
                self.effort[name] = message.effort[idx]  # IndexError without efforts

    def _on_endpoint(self, message: Any) -> None:
        p, o = message.pose.position, message.pose.orientation
        self.pose = {"position": (p.x, p.y, p.z), "orientation": (o.x, o.y, o.z, o.w)}

    def close(self) -> None:
        for sub in self._subs:
            sub.unregister()


class GripperClient:
    """One gripper, as `Gripper` drives it."""

    def __init__(self, rospy: Any, side: str) -> None:
        self.baxter = importlib.import_module("baxter_core_msgs.msg")
        self.rospy = rospy
        ns = f"robot/end_effector/{side}_gripper/"
        self.state: Any = None
        self.properties: Any = None
        self.sequence = 0
        self.parameters: dict[str, float] = {}
        self._command = rospy.Publisher(
            ns + "command", self.baxter.EndEffectorCommand, queue_size=10
        )
        self._subs = [
            rospy.Subscriber(ns + "state", self.baxter.EndEffectorState, self._on_state),
            rospy.Subscriber(ns + "properties", self.baxter.EndEffectorProperties, self._on_props),
        ]
        assert _wait(lambda: self.state is not None, 5.0), "Failed to get state"
        assert _wait(lambda: self.type() is not None, 5.0), "Failed to get properties"
        self.set_parameters()

    def _on_state(self, message: Any) -> None:
        self.state = message

    def _on_props(self, message: Any) -> None:
        self.properties = message

    def type(self) -> str | None:
        if self.properties is None:
            return None
        kinds = {1: "suction", 2: "electric", 3: "custom"}
        return kinds.get(self.properties.ui_type)

    def firmware_ok(self) -> bool:
        built = time.strptime(self.properties.firmware_date, "%Y/%m/%d %H:%M:%S")
        return built > time.strptime(FIRMWARE_FAIL_BEFORE, "%Y/%m/%d %H:%M:%S")

    def command(
        self,
        name: str,
        test: Callable[[], bool] = lambda: True,
        timeout_s: float = 0.0,
        **args: Any,
    ) -> bool:
        """Sends a command with the state's id; waits for its acknowledgement, then `test`."""
        self.sequence += 1
        sender = f"{self.rospy.get_name()}_{name}"
        message = self.baxter.EndEffectorCommand(
            id=self.state.id,
            command=name,
            args=json.dumps(args) if args else "",
            sender=sender,
            sequence=self.sequence,
        )
        self._command.publish(message)
        if not timeout_s:
            return True
        seq = self.sequence
        acked = lambda: (  # noqa: E731
            self.state.command_sender == sender and self.state.command_sequence in (seq, 0)
        )
        _wait(acked, timeout_s, lambda: self._command.publish(message))
        return _wait(test, max(0.5, timeout_s), lambda: self._command.publish(message))

    def set_parameters(self) -> None:
        if self.type() == "electric":
            self.parameters = {
                "velocity": 50.0,
                "moving_force": 40.0,
                "holding_force": 30.0,
                "dead_zone": 5.0,
            }
        else:
            self.parameters = {"vacuum_sensor_threshold": 18.0, "blow_off_seconds": 0.4}
        self.command("configure", **self.parameters)

    def calibrate(self) -> bool | None:
        if self.type() != "electric":
            return None  # "not capable of 'calibrate'": nothing is sent
        s = lambda: self.state  # noqa: E731
        if s().calibrated:
            self.command("clear_calibration", lambda: not s().calibrated and s().ready, 2.0)
        if s().error:
            self.command("reset", lambda: not s().error and s().ready, 2.0)
        done = self.command("calibrate", lambda: s().calibrated and s().ready, 5.0)
        self.set_parameters()
        return done

    def close(self, timeout_s: float = 5.0) -> bool:
        if self.type() == "suction":
            return self.command(
                "go", self.vacuum, timeout_s, grip_attempt_seconds=timeout_s
            )  # fmt: skip
        return self.position(0.0, timeout_s)

    def open(self, timeout_s: float = 5.0) -> bool:
        if self.type() == "suction":
            timeout_s = max(self.parameters["blow_off_seconds"], timeout_s)
            idle = lambda: not (self._json()["sucking"] or self._json()["blowing"])  # noqa: E731
            return self.command("release", idle, timeout_s)
        return self.position(100.0, timeout_s)

    def position(self, target: float, timeout_s: float) -> bool:
        if not self.state.calibrated:
            return False  # "Unable to command position until calibrated"
        reached = lambda: (  # noqa: E731
            abs(self.state.position - target) < self.parameters["dead_zone"] or self.state.gripping
        )
        return self.command("go", reached, timeout_s, position=target)

    def _json(self) -> dict[str, Any]:
        decoded: dict[str, Any] = json.loads(self.state.state)
        return decoded

    def vacuum(self) -> bool:
        return bool(self._json()["vacuum"])

    def close_subscriptions(self) -> None:
        for sub in self._subs:
            sub.unregister()


@contextmanager
def _sim(*arguments: str) -> Iterator[None]:
    """`tandem robot sim` on the shared master with `arguments`, until its ready line."""
    master = shared_master()
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "robot", "sim", "--master", master.uri, *arguments],
        cwd=ROOT, env=master.env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(
        target=lambda: [lines.put(x) for x in process.stdout or []], daemon=True
    ).start()
    try:
        deadline = time.monotonic() + 60.0
        while not lines.get(timeout=max(deadline - time.monotonic(), 0.01)).startswith(
            "simulated Baxter ready on "
        ):
            pass
        yield
    finally:
        process.terminate()
        assert process.wait(15.0) == 0


@pytest.fixture(scope="module")
def rospy() -> Iterator[Any]:
    if not ros_installed():
        pytest.skip("ROS 1 is not installed: make robot")
    with _sim("--enabled", "no", "--gripper", "right=suction"):
        yield ros_node(shared_master())


def test_the_enable_client_finds_a_disabled_robot_enables_stops_and_enables_it(rospy: Any) -> None:
    robot = EnableClient(rospy)
    try:
        assert robot.version_ok()
        assert not robot.state.enabled and not robot.state.stopped  # as Baxter boots
        robot.enable()
        assert robot.state.ready
        robot.stop()
        assert not robot.state.enabled and robot.state.estop_source == 2  # asserted by software
        robot.enable()  # resets first, as RobotEnable.enable does
        assert robot.state.enabled and not robot.state.stopped
    finally:
        robot.close()


def test_the_limb_client_reads_efforts_and_the_endpoint_and_the_arm_moves(rospy: Any) -> None:
    robot = EnableClient(rospy)
    robot.enable()
    robot.close()
    limb = LimbClient(rospy, "left")
    try:
        assert set(limb.effort) == set(limb.names)
        assert abs(limb.effort["left_s1"]) > 10.0  # the shoulder holds the arm up
        before = limb.pose["position"]
        actionlib = importlib.import_module("actionlib")
        control = importlib.import_module("control_msgs.msg")
        messages = importlib.import_module("trajectory_msgs.msg")
        client = actionlib.SimpleActionClient(
            "robot/limb/left/follow_joint_trajectory", control.FollowJointTrajectoryAction
        )
        assert client.wait_for_server(rospy.Duration(10.0))
        goal = control.FollowJointTrajectoryGoal()
        goal.goal_time_tolerance = rospy.Duration(0.1)
        goal.trajectory.joint_names = list(limb.names)
        target = [limb.angle[n] for n in limb.names]
        target[0] += 0.3  # left_s0: the arm swings about the vertical
        goal.trajectory.points = [
            messages.JointTrajectoryPoint(positions=target, time_from_start=rospy.Duration(1.0))
        ]
        goal.trajectory.header.stamp = rospy.Time.now()
        client.send_goal(goal)
        assert client.wait_for_result(rospy.Duration(10.0)) and client.get_state() == SUCCEEDED
        assert _wait(lambda: abs(limb.angle["left_s0"] - target[0]) < 1e-6, 2.0)
        after = limb.pose["position"]
        # A swing about the vertical axis keeps the height and the distance to it.
        assert after[2] == pytest.approx(before[2], abs=1e-3)
        assert math.dist(after[:2], before[:2]) > 0.1
        goal.trajectory.points[0].positions = list(HOME["left"])
        client.send_goal(goal)
        assert client.wait_for_result(rospy.Duration(10.0))
    finally:
        limb.close()


def test_the_gripper_client_calibrates_the_electric_gripper_and_closes_and_opens_it(
    rospy: Any,
) -> None:
    gripper = GripperClient(rospy, "left")
    try:
        assert gripper.type() == "electric" and gripper.state.id == 65538
        assert gripper.firmware_ok() and gripper.properties.has_calibration
        assert not gripper.close(1.0)  # not calibrated: the client refuses to send go
        assert gripper.calibrate()
        assert gripper.close()
        assert gripper.state.gripping and gripper.state.force > 0.0  # a part held
        assert gripper.open()
        assert gripper.state.position == pytest.approx(100.0) and not gripper.state.gripping
    finally:
        gripper.close_subscriptions()


def test_the_gripper_client_sucks_and_releases_with_the_suction_cup(rospy: Any) -> None:
    gripper = GripperClient(rospy, "right")
    try:
        assert gripper.type() == "suction" and gripper.state.id == 65537
        assert gripper.calibrate() is None and gripper.state.calibrated == 1
        assert gripper.close()
        assert gripper.vacuum() and gripper.state.gripping
        assert gripper.open()
        assert not gripper.vacuum() and not gripper.state.gripping
    finally:
        gripper.close_subscriptions()


def test_the_planned_paths_stay_on_what_ompl_checked_when_splined() -> None:
    """The server's spline leaves the straight segments between waypoints that OMPL
    checked; for the default plan's paths, timed as the link times them, it stays
    closer to them than half OMPL's validity-checking step (so within what the
    checker's resolution already trusted). A coarse path with a corner does not:
    the check can fail."""
    limits = _arm_extent()
    half_step = RESOLUTION * limits / 2  # OMPL's step: a share of the space's extent
    worst = 0.0
    motions = [n.motion for n in default_plan().nodes.values() if n.motion is not None]
    assert len(motions) > 10
    for motion in motions:
        trajectory = timed(motion.arm, motion.joints, motion.path)
        spline = BezierSpline(trajectory.times, trajectory.points)
        worst = max(worst, _farthest_from_polyline(spline.sample(20), np.array(trajectory.points)))
    assert worst < half_step
    corner = np.array([HOME["left"], HOME["left"], HOME["left"]])
    corner[1, 0] += 0.5
    corner[2, 0] += 0.5
    corner[2, 2] += 0.5
    coarse = BezierSpline([0.0, 0.6, 2.0], corner)
    assert _farthest_from_polyline(coarse.sample(50), corner) > half_step


def _arm_extent() -> float:
    """The joint space's extent (its diagonal) for one arm, from the URDF's limits."""
    from xml.etree import ElementTree

    root = ElementTree.parse(baxter_urdf()).getroot()
    spans = []
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if joint.get("name") in joint_names("left") and limit is not None:
            spans.append(float(limit.get("upper", 0)) - float(limit.get("lower", 0)))
    assert len(spans) == 7
    return float(np.linalg.norm(spans))


def _farthest_from_polyline(samples: np.ndarray, points: np.ndarray) -> float:
    """The largest distance (joint space) from a sample to the nearest segment."""
    a, b = points[:-1], points[1:]
    d = b - a
    length = np.maximum((d * d).sum(axis=1), 1e-18)
    worst = 0.0
    for q in samples:
        u = np.clip(((q - a) * d).sum(axis=1) / length, 0.0, 1.0)
        nearest = a + u[:, None] * d
        worst = max(worst, float(np.min(np.linalg.norm(q - nearest, axis=1))))
    return worst
