"""The robot link: the one protocol through which the executor moves a robot.

The executor hands a `RobotLink` each actuation node's motion as a
time-parameterised joint `Trajectory` and the node's gripper command, and waits
for a `Followed` report: the trajectory reached its end, or a fault stopped it
(`FaultCause`), with the robot's last joint state either way. The link streams
the robot's joint states to whoever watches them (the dashboard's drawn arm).

Backends: the drawing (the executor's own playback; no link object at all) and
ROS 1 as Baxter speaks it (`app.robot.ros_link`). A ROS 2 backend is one more
class with these five methods (an rclpy action client for
`control_msgs/action/FollowJointTrajectory`, a `sensor_msgs/msg/JointState`
subscription): nothing above the link changes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal, Protocol

Side = Literal["left", "right"]
# What a hold or an unhold asks of the gripper once the arm arrived: close on the part,
# or open. The link turns it into the gripper's own commands (Baxter's electric gripper:
# `go` to position 0 or 100; its suction cup: suction on, or `release`).
GripperCommand = Literal["grip", "release"]
# Why a link could not do what it was asked:
# `no-master`: no ROS master answers; `no-server`: no trajectory action server;
# `rejected`: the robot refused the trajectory before moving (a limit);
# `aborted`: the robot stopped the trajectory under way; `preempted`: it was
# cancelled (by Pause, Abort or the voice's "stop"); `silent`: the joint states
# stopped coming; `master-lost`: the master went away mid-session; `off-start`: the
# robot stands away from where a motion starts and no safe motion there was found;
# `disabled`: the robot is not enabled (before a motion: it refuses; during one: it
# was disabled); `estop`: the robot is stopped (its e-stop, or a stop from software);
# `off-goal`: a motion ended (the robot said succeeded) with a joint farther from its
# end than `GOAL_TOLERANCE_RAD`; `gripper`: the gripper is missing, in error, or did
# not do what it was told; `no-result`: the robot never said how a motion ended (its
# action server lost the goal, or no result came long after the motion's end).
FaultCause = Literal[
    "no-master", "no-server", "rejected", "aborted", "preempted", "silent", "master-lost",
    "off-start", "disabled", "estop", "off-goal", "gripper", "no-result",
]  # fmt: skip
# A robot that refuses to move in the state it is in: the operator must act on it
# (enable it, release its e-stop) before a run can go on.
REFUSALS: tuple[FaultCause, ...] = ("disabled", "estop")
# Every goal carries these tolerances, and the arrival is checked against the robot's
# joint states with the same bound. 0.02 rad: about twice what Baxter's series-elastic
# joints hold a still position to, and below the driver's start tolerance (0.05 rad), so
# an arm that arrived always starts the next motion where it is.
GOAL_TOLERANCE_RAD = 0.02
# How late the arm may reach the end: half a second for a loaded arm to settle. Rethink's
# trajectory action server commands the final point for this long after the trajectory's
# end and only then checks the goal, so every motion lasts this much longer on it.
GOAL_TIME_TOLERANCE_S = 0.5
# The largest error allowed along the way (each joint): Rethink's server's own default,
# sent explicitly so a server configured otherwise cannot loosen it.
PATH_TOLERANCE_RAD = 0.2
Joints = dict[str, float]  # joint name (`left_s0`, ...) -> radians


@dataclass(frozen=True)
class Trajectory:
    """One arm's motion: its joints' names, the waypoints, and when each is reached
    (seconds from the start; the first is 0)."""

    arm: Side
    joints: tuple[str, ...]
    points: tuple[tuple[float, ...], ...]
    times: tuple[float, ...]

    def final(self) -> Joints:
        return dict(zip(self.joints, self.points[-1], strict=True))

    @property
    def seconds(self) -> float:
        return self.times[-1] if self.times else 0.0


@dataclass(frozen=True)
class JointState:
    """The robot's joints at one moment (the link's clock, seconds)."""

    stamp: float
    positions: Mapping[str, float]


@dataclass(frozen=True)
class Followed:
    """How a trajectory ended: `cause` None when it reached its end; `joints` the
    robot's last joint state; `samples` the arm's joint states seen along the way
    (seconds from `began`, positions in the trajectory's joint order); `began` the
    wall-clock time the goal was sent (None when none was)."""

    cause: FaultCause | None
    detail: str
    joints: Joints
    samples: tuple[tuple[float, tuple[float, ...]], ...] = ()
    began: float | None = None

    @property
    def ok(self) -> bool:
        return self.cause is None


class RobotFault(Exception):
    """The link cannot go on: its cause, and a line an operator can read."""

    def __init__(self, cause: FaultCause, line: str, joints: Joints | None = None) -> None:
        super().__init__(line)
        self.cause = cause
        self.line = line
        self.joints = joints or {}


JointListener = Callable[[JointState], None]


class RobotLink(Protocol):
    """A robot the executor drives. `follow` blocks until the trajectory ends;
    `cancel` (from any thread) stops it within a control tick."""

    name: str

    def connect(self, timeout_s: float) -> None:
        """Reaches the robot, or raises `RobotFault` (`no-master`, `no-server`)."""
        ...

    def advertised(self) -> str:
        """One line: where the robot reaches this program (a ROS node's address)."""
        ...

    def joints(self) -> Joints:
        """The latest joint state, or raises `RobotFault` (`silent`, `master-lost`)."""
        ...

    def check_ready(self) -> None:
        """Raises `RobotFault` (`disabled`, `estop`) when the robot would not move now."""
        ...

    def follow(self, trajectory: Trajectory, gripper: GripperCommand | None) -> Followed:
        """Sends `trajectory`, then `gripper` once it reached its end."""
        ...

    def cancel(self) -> None: ...

    def watch(self, listener: JointListener) -> Callable[[], None]:
        """Calls `listener` with every joint state; returns how to stop."""
        ...

    def close(self) -> None: ...


def arm_joints(joints: Mapping[str, float], names: Sequence[str]) -> tuple[float, ...]:
    """`joints` of `names`, in that order (a joint the state lacks raises KeyError)."""
    return tuple(float(joints[n]) for n in names)


def off_goal(joints: Mapping[str, float], goal: Mapping[str, float]) -> tuple[str, float] | None:
    """The joint farthest from `goal` and its error (radians, signed: goal - where it is),
    when more than `GOAL_TOLERANCE_RAD`; None when every joint arrived. A joint the state
    lacks counts as not arrived (error nan)."""
    if not goal:
        return None
    errors = {name: q - joints.get(name, float("nan")) for name, q in goal.items()}
    worst = max(errors, key=lambda n: abs(errors[n]) if errors[n] == errors[n] else float("inf"))
    error = errors[worst]
    return (worst, error) if not abs(error) <= GOAL_TOLERANCE_RAD else None


def farthest(a: Sequence[float], b: Sequence[float]) -> float:
    """The largest joint difference between two configurations (radians)."""
    return max((abs(x - y) for x, y in zip(a, b, strict=True)), default=0.0)
