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
# Baxter's gripper commands (baxter_core_msgs/EndEffectorCommand).
GripperCommand = Literal["grip", "release"]
# Why a link could not do what it was asked:
# `no-master`: no ROS master answers; `no-server`: no trajectory action server;
# `rejected`: the robot refused the trajectory before moving (a limit);
# `aborted`: the robot stopped the trajectory under way; `preempted`: it was
# cancelled (by Pause, Abort or the voice's "stop"); `silent`: the joint states
# stopped coming; `master-lost`: the master went away mid-session; `off-start`: the
# robot stands away from where a motion starts and no safe motion there was found.
FaultCause = Literal[
    "no-master", "no-server", "rejected", "aborted", "preempted", "silent", "master-lost",
    "off-start",
]  # fmt: skip
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
    (seconds from the start, positions in the trajectory's joint order)."""

    cause: FaultCause | None
    detail: str
    joints: Joints
    samples: tuple[tuple[float, tuple[float, ...]], ...] = ()

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

    def joints(self) -> Joints:
        """The latest joint state, or raises `RobotFault` (`silent`, `master-lost`)."""
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


def farthest(a: Sequence[float], b: Sequence[float]) -> float:
    """The largest joint difference between two configurations (radians)."""
    return max((abs(x - y) for x, y in zip(a, b, strict=True)), default=0.0)
