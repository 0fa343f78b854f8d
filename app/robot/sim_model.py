"""The simulated Baxter's body, without ROS: pybullet's Baxter moved kinematically,
the URDF's joint limits, the checks a trajectory passes before it moves, and the
electric grippers.

`tandem robot sim` (`app.robot.sim_node`) serves this body over Baxter's ROS
interface. A trajectory is followed by linear interpolation between its points
at their `time_from_start`, starting from where the arm is at time 0.
"""

from __future__ import annotations

import bisect
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

from planner.feasibility._bullet import pb, silenced  # pybullet without its stdout chatter
from planner.feasibility.arms import ARMS, HOME, joint_names
from planner.feasibility.robot import baxter_urdf

Side = Literal["left", "right"]
# Why a trajectory is refused before it moves (control_msgs' error codes' names).
RejectCode = Literal["INVALID_JOINTS", "INVALID_GOAL"]
GripperCommand = Literal["grip", "release"]

# Allowance over the URDF's velocity limits: waypoint times are rounded (to the
# nanosecond in the message, to the millisecond by some planners), and a segment
# timed at exactly the limit must pass.
VELOCITY_TOLERANCE = 0.05  # a share of the limit
POSITION_TOLERANCE = 1e-4  # rad beyond a position limit, for rounding
# A first waypoint at time 0 may sit this far from where the arm is (a jump a real
# controller absorbs); farther, the trajectory does not start where the arm is.
START_TOLERANCE = 0.05  # rad
GRIPPER_SECONDS = 0.4  # fully open to closed
GRIPPER_OPENING_M = 0.020833  # each finger's travel (the URDF's finger limits)
FINGERS = {
    "left": ("l_gripper_l_finger_joint", "l_gripper_r_finger_joint"),
    "right": ("r_gripper_l_finger_joint", "r_gripper_r_finger_joint"),
}
ARM_JOINTS = tuple(name for arm in ARMS for name in joint_names(arm))
HOME_JOINTS = {name: q for arm in ARMS for name, q in zip(joint_names(arm), HOME[arm], strict=True)}


class StartBeyondLimits(ValueError):
    """The joints the body was asked to start at break the URDF's limits."""


@dataclass(frozen=True)
class JointLimit:
    lower: float
    upper: float
    velocity: float  # rad/s


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

    def at(self, t: float) -> tuple[float, ...]:
        """The positions `t` seconds in (linear between waypoints; the last one after)."""
        if t >= self.times[-1]:
            return self.points[-1]
        i = max(bisect.bisect_right(self.times, t) - 1, 0)
        t0, t1 = self.times[i], self.times[i + 1]
        share = (t - t0) / (t1 - t0)
        before, after = self.points[i], self.points[i + 1]
        return tuple(a + (b - a) * share for a, b in zip(before, after, strict=True))


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


@dataclass
class Gripper:
    """One electric gripper: opening in percent (0 closed, 100 open) and its last command."""

    position: float = 100.0
    target: float = 100.0
    # No object is simulated: a grip is taken to hold what the plan says it holds.
    gripping: bool = False
    command: str = ""
    sender: str = ""
    sequence: int = 0

    @property
    def moving(self) -> bool:
        return self.position != self.target

    def step(self, seconds: float) -> None:
        reach = 100.0 * seconds / GRIPPER_SECONDS
        delta = self.target - self.position
        self.position = (
            self.target if abs(delta) <= reach else self.position + reach * (1 if delta > 0 else -1)
        )


class BaxterModel:
    """Baxter in pybullet (DIRECT, or a window), its joints set kinematically; safe
    to use from several threads."""

    def __init__(self, start: Mapping[str, float] | None = None, gui: bool = False) -> None:
        self._lock = threading.Lock()
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        with silenced():  # "No inertial data" warnings for the massless frames
            self.body = pb.loadURDF(
                str(baxter_urdf()),
                useFixedBase=True,
                flags=pb.URDF_IGNORE_VISUAL_SHAPES if not gui else 0,
                physicsClientId=self.client,
            )
        self.index: dict[str, int] = {}
        self.limits: dict[str, JointLimit] = {}
        for j in range(pb.getNumJoints(self.body, physicsClientId=self.client)):
            info = pb.getJointInfo(self.body, j, physicsClientId=self.client)
            if info[2] != pb.JOINT_FIXED:
                name = info[1].decode()
                self.index[name] = j
                self.limits[name] = JointLimit(float(info[8]), float(info[9]), float(info[11]))
        self.names = (*ARM_JOINTS, *FINGERS["left"], *FINGERS["right"])
        self.grippers: dict[Side, Gripper] = {"left": Gripper(), "right": Gripper()}
        self._velocity = dict.fromkeys(self.names, 0.0)
        joints = {**HOME_JOINTS, **(start or {})}
        outside = [n for n, v in joints.items() if not _within(self.limits[n], v)]
        if outside:
            raise StartBeyondLimits(f"start beyond the joint limits: {', '.join(outside)}")
        self.set(joints)
        for side in self.grippers:
            self._place_fingers(side)

    def set(self, joints: Mapping[str, float], velocity: Mapping[str, float] | None = None) -> None:
        with self._lock:
            for name, value in joints.items():
                pb.resetJointState(self.body, self.index[name], value, physicsClientId=self.client)
                self._velocity[name] = (velocity or {}).get(name, 0.0)

    def positions(self) -> dict[str, float]:
        with self._lock:
            states = pb.getJointStates(
                self.body, [self.index[n] for n in self.names], physicsClientId=self.client
            )
            return {n: float(s[0]) for n, s in zip(self.names, states, strict=True)}

    def velocities(self) -> dict[str, float]:
        with self._lock:
            return dict(self._velocity)

    def command_gripper(self, side: Side, command: GripperCommand, sender: str, seq: int) -> None:
        with self._lock:
            gripper = self.grippers[side]
            gripper.target = 0.0 if command == "grip" else 100.0
            gripper.gripping = command == "grip"
            gripper.command, gripper.sender, gripper.sequence = command, sender, seq

    def step_grippers(self, seconds: float) -> None:
        for side, gripper in self.grippers.items():
            if gripper.moving:
                with self._lock:
                    gripper.step(seconds)
                self._place_fingers(side)

    def _place_fingers(self, side: Side) -> None:
        opening = self.grippers[side].position / 100.0 * GRIPPER_OPENING_M
        left_finger, right_finger = FINGERS[side]
        self.set({left_finger: opening, right_finger: -opening})

    def close(self) -> None:
        pb.disconnect(physicsClientId=self.client)


def _within(limit: JointLimit, value: float) -> bool:
    return limit.lower - POSITION_TOLERANCE <= value <= limit.upper + POSITION_TOLERANCE
