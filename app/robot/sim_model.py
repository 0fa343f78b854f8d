"""The simulated Baxter's body, without ROS: pybullet's Baxter moved kinematically,
the URDF's joint limits, the checks a trajectory passes before it moves, and the
grippers (`app.robot.sim_gripper`).

`tandem robot sim` (`app.robot.sim_node`) serves this body over Baxter's ROS
interface. A trajectory is followed along the real server's spline through its
points at their `time_from_start` (`app.robot.sim_spline`), starting from where
the arm is at time 0. The joint efforts are the gravity torques of the URDF's
masses where the arm is (an arm at rest carries its own weight), and each
gripper's endpoint pose and twist come from the URDF's forward kinematics.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

from app.robot.sim_gripper import Gripper, GripperKind
from app.robot.sim_spline import BezierSpline
from planner.feasibility._bullet import pb, silenced  # pybullet without its stdout chatter
from planner.feasibility.arms import ARMS, HOME, joint_names
from planner.feasibility.robot import baxter_urdf

Side = Literal["left", "right"]
SIDES: tuple[Side, Side] = ("left", "right")
# Why a trajectory is refused before it moves (control_msgs' error codes' names).
RejectCode = Literal["INVALID_JOINTS", "INVALID_GOAL"]

# Allowance over the URDF's velocity limits: waypoint times are rounded (to the
# nanosecond in the message, to the millisecond by some planners), and a segment
# timed at exactly the limit must pass.
VELOCITY_TOLERANCE = 0.05  # a share of the limit
POSITION_TOLERANCE = 1e-4  # rad beyond a position limit, for rounding
# A first waypoint at time 0 may sit this far from where the arm is (a jump a real
# controller absorbs); farther, the trajectory does not start where the arm is.
START_TOLERANCE = 0.05  # rad
GRIPPER_OPENING_M = 0.020833  # each finger's travel (the URDF's finger limits)
FINGERS = {
    "left": ("l_gripper_l_finger_joint", "l_gripper_r_finger_joint"),
    "right": ("r_gripper_l_finger_joint", "r_gripper_r_finger_joint"),
}
ARM_JOINTS = tuple(name for arm in ARMS for name in joint_names(arm))
ENDPOINT_LINKS = {"left": "left_gripper", "right": "right_gripper"}  # Baxter's endpoint frames
GRAVITY = 9.81  # m/s^2
HOME_JOINTS = {name: q for arm in ARMS for name, q in zip(joint_names(arm), HOME[arm], strict=True)}


class StartBeyondLimits(ValueError):
    """The joints the body was asked to start at break the URDF's limits."""


@dataclass(frozen=True)
class JointLimit:
    lower: float
    upper: float
    velocity: float  # rad/s


Vector = tuple[float, ...]


@dataclass(frozen=True)
class Endpoint:
    """A gripper's endpoint frame: position (m), orientation (x, y, z, w), and
    linear (m/s) and angular (rad/s) velocity, in the base frame."""

    position: Vector
    orientation: Vector
    linear: Vector
    angular: Vector


@dataclass(frozen=True)
class Rejection:
    code: RejectCode
    text: str


@dataclass(frozen=True)
class Motion:
    """A checked trajectory of some of one arm's joints: `times[0]` is 0 and
    `points[0]` where the arm was when it began."""

    joints: tuple[str, ...]
    times: tuple[float, ...]
    points: tuple[tuple[float, ...], ...]

    @property
    def seconds(self) -> float:
        return self.times[-1]

    @cached_property
    def spline(self) -> BezierSpline:
        """The path commanded between the waypoints (the real server's spline)."""
        return BezierSpline(self.times, self.points)

    def at(self, t: float) -> tuple[dict[str, float], dict[str, float]]:
        """The commanded positions and velocities `t` seconds in (the last point,
        at rest, after the end)."""
        position, velocity = self.spline.at(t)
        return (
            dict(zip(self.joints, position.tolist(), strict=True)),
            dict(zip(self.joints, velocity.tolist(), strict=True)),
        )

    @property
    def last(self) -> dict[str, float]:
        return dict(zip(self.joints, self.points[-1], strict=True))


def check_motion(
    side: Side,
    names: Sequence[str],
    times: Sequence[float],
    points: Sequence[Sequence[float]],
    now: Mapping[str, float],
    limits: Mapping[str, JointLimit],
) -> Motion | Rejection:
    """The motion of a trajectory goal, or why it is refused before moving: joints
    not of this arm (or twice), waypoints of the wrong length or not in time order,
    a position beyond the URDF's limits, a segment faster than its velocity limits."""
    arm = joint_names(side)
    unknown = [n for n in names if n not in arm]
    if unknown or len(set(names)) != len(names) or not names:
        what = ", ".join(unknown) if unknown else "repeated or no joint names"
        return Rejection("INVALID_JOINTS", f"not joints of the {side} arm: {what}")
    for k, q in enumerate(points):
        if len(q) != len(names):
            return Rejection(
                "INVALID_GOAL", f"waypoint {k} has {len(q)} positions for {len(names)} joints"
            )
        for name, v in zip(names, q, strict=True):
            limit = limits[name]
            if not limit.lower - POSITION_TOLERANCE <= v <= limit.upper + POSITION_TOLERANCE:
                return Rejection(
                    "INVALID_GOAL",
                    f"waypoint {k}: {name} at {v:.4f} rad is beyond its limits "
                    f"[{limit.lower:.4f}, {limit.upper:.4f}]",
                )
    start = tuple(now[n] for n in names)
    all_times, all_points = [0.0], [start]
    for k, (t, q) in enumerate(zip(times, points, strict=True)):
        if t < all_times[-1] or (k > 0 and t == all_times[-1]):
            return Rejection(
                "INVALID_GOAL", f"waypoint {k} at {t:.3f} s is not after the one before"
            )
        if t == 0.0:  # replaces where the arm is, if close enough
            jump = max(abs(a - b) for a, b in zip(q, start, strict=True))
            if jump > START_TOLERANCE:
                return Rejection(
                    "INVALID_GOAL",
                    f"the trajectory starts {jump:.3f} rad from where the {side} arm is",
                )
            all_points[0] = tuple(q)
            continue
        all_times.append(t)
        all_points.append(tuple(q))
    if len(all_times) == 1:  # a single point at time 0: a jump within the tolerance
        all_times.append(1e-3)
        all_points.append(all_points[0])
    too_fast = _too_fast(names, all_times, all_points, limits)
    if too_fast is not None:
        return Rejection("INVALID_GOAL", too_fast)
    return Motion(tuple(names), tuple(all_times), tuple(all_points))


def _too_fast(
    names: Sequence[str],
    times: Sequence[float],
    points: Sequence[tuple[float, ...]],
    limits: Mapping[str, JointLimit],
) -> str | None:
    for k in range(1, len(times)):
        dt = times[k] - times[k - 1]
        for j, name in enumerate(names):
            speed = abs(points[k][j] - points[k - 1][j]) / dt
            allowed = limits[name].velocity * (1.0 + VELOCITY_TOLERANCE)
            if speed > allowed:
                return (
                    f"{name} needs {speed:.3f} rad/s from {times[k - 1]:.3f} s "
                    f"to {times[k]:.3f} s, over its limit of {limits[name].velocity:.3f} rad/s"
                )
    return None


class BaxterModel:
    """Baxter in pybullet (DIRECT, or a window), its joints set kinematically; safe
    to use from several threads."""

    def __init__(
        self,
        start: Mapping[str, float] | None = None,
        gui: bool = False,
        grippers: Mapping[Side, GripperKind] | None = None,
    ) -> None:
        self._lock = threading.Lock()
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        # Only for the efforts' inverse dynamics: the body is never simulated.
        pb.setGravity(0.0, 0.0, -GRAVITY, physicsClientId=self.client)
        with silenced():  # "No inertial data" warnings for the massless frames
            self.body = pb.loadURDF(
                str(baxter_urdf()),
                useFixedBase=True,
                flags=pb.URDF_IGNORE_VISUAL_SHAPES if not gui else 0,
                physicsClientId=self.client,
            )
        self.index: dict[str, int] = {}
        self.limits: dict[str, JointLimit] = {}
        self.links: dict[str, int] = {}  # a link's index is its parent joint's
        for j in range(pb.getNumJoints(self.body, physicsClientId=self.client)):
            info = pb.getJointInfo(self.body, j, physicsClientId=self.client)
            self.links[info[12].decode()] = j
            if info[2] != pb.JOINT_FIXED:
                name = info[1].decode()
                self.index[name] = j
                self.limits[name] = JointLimit(float(info[8]), float(info[9]), float(info[11]))
        self.names = (*ARM_JOINTS, *FINGERS["left"], *FINGERS["right"])
        kinds: dict[Side, GripperKind] = {"left": "electric", "right": "electric"}
        kinds.update(grippers or {})
        self.grippers: dict[Side, Gripper] = {side: Gripper(kinds[side]) for side in SIDES}
        self._velocity = dict.fromkeys(self.names, 0.0)
        self._moved_at: dict[str, float] = {}  # joints in motion: when last set (epoch s)
        joints = {**HOME_JOINTS, **(start or {})}
        outside = [n for n, v in joints.items() if not _within(self.limits[n], v)]
        if outside:
            raise StartBeyondLimits(f"start beyond the joint limits: {', '.join(outside)}")
        self.set(joints)
        for side in self.grippers:
            self._place_fingers(side)

    def set(
        self,
        joints: Mapping[str, float],
        velocity: Mapping[str, float] | None = None,
        at: float | None = None,
    ) -> None:
        """Puts `joints` there, moving at `velocity`, as of epoch time `at` (now)."""
        with self._lock:
            now = time.time() if at is None else at
            for name, value in joints.items():
                speed = (velocity or {}).get(name, 0.0)
                pb.resetJointState(
                    self.body, self.index[name], value, speed, physicsClientId=self.client
                )
                self._velocity[name] = speed
                if speed:
                    self._moved_at[name] = now
                else:
                    self._moved_at.pop(name, None)

    def reading(self) -> tuple[dict[str, float], dict[str, float], float | None]:
        """Positions, velocities and when the joints in motion were put there (epoch s,
        the oldest of them; None when none moves), read at once. A joint state is stamped
        with that time: the arm stands at a tick's position until the next tick, which
        comes late on a busy machine."""
        with self._lock:
            moved_at = min(self._moved_at.values(), default=None)
            return self._positions(), dict(self._velocity), moved_at

    def positions(self) -> dict[str, float]:
        with self._lock:
            return self._positions()

    def _positions(self) -> dict[str, float]:
        states = pb.getJointStates(
            self.body, [self.index[n] for n in self.names], physicsClientId=self.client
        )
        return {n: float(s[0]) for n, s in zip(self.names, states, strict=True)}

    def velocities(self) -> dict[str, float]:
        with self._lock:
            return dict(self._velocity)

    def efforts(self) -> dict[str, float]:
        """Each joint's torque (N m) holding the arms where they are against gravity."""
        with self._lock:
            order = sorted(self.index, key=self.index.__getitem__)
            states = pb.getJointStates(
                self.body, [self.index[n] for n in order], physicsClientId=self.client
            )
            torques = pb.calculateInverseDynamics(
                self.body,
                [float(s[0]) for s in states],
                [float(s[1]) for s in states],
                [0.0] * len(order),
                physicsClientId=self.client,
            )
        effort = dict(zip(order, (float(t) for t in torques), strict=True))
        return {name: effort[name] for name in self.names}

    def endpoint(self, side: Side) -> Endpoint:
        """The gripper's endpoint frame in the base frame, and its twist."""
        with self._lock:
            state = pb.getLinkState(
                self.body,
                self.links[ENDPOINT_LINKS[side]],
                computeLinkVelocity=1,
                computeForwardKinematics=1,
                physicsClientId=self.client,
            )
        position, orientation, linear, angular = state[4], state[5], state[6], state[7]
        return Endpoint(
            tuple(position), tuple(orientation), tuple(linear), tuple(angular)
        )  # fmt: skip

    def step_grippers(self, seconds: float) -> None:
        for side, gripper in self.grippers.items():
            was = gripper.position
            gripper.step(seconds)
            if gripper.position != was:
                self._place_fingers(side)

    def _place_fingers(self, side: Side) -> None:
        """The electric gripper's fingers where its position says (a suction cup's
        stay open: the URDF has the electric gripper's fingers)."""
        gripper = self.grippers[side]
        percent = gripper.position if gripper.kind == "electric" else 100.0
        opening = percent / 100.0 * GRIPPER_OPENING_M
        left_finger, right_finger = FINGERS[side]
        self.set({left_finger: opening, right_finger: -opening})

    def close(self) -> None:
        pb.disconnect(physicsClientId=self.client)


def _within(limit: JointLimit, value: float) -> bool:
    return limit.lower - POSITION_TOLERANCE <= value <= limit.upper + POSITION_TOLERANCE
