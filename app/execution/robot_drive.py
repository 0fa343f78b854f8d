"""Driving the robot behind a link through the plan's actuation nodes.

The executor hands each actuation node's motion to a `RobotDriver`, which
times the joint path within Baxter's velocity limits (`timed`), starts where
the robot is, and reports what the robot did as a `RobotMotion` record:

- **Start where the robot is.** Before a motion, and again after a fault, the
  robot's joints are compared with the motion's first waypoint; off by more
  than `START_TOLERANCE_RAD`, a planned motion (`ToStart`: OMPL on the bench,
  collision-checked) takes the arm there first, or the driver refuses with a
  fault saying so.
- **Pause and abort** cancel the goal under way (`cancel`); resumed, the arm
  goes on from the waypoint nearest to where it stopped.
- **Ready, and arrived.** Before each motion the link says whether the robot
  would move (enabled, not stopped); if not, the motion is refused (`refused`
  keeps why, so the command line can say the robot, not the plan, stopped the
  run). A motion the robot reports as reached counts only when every joint is
  within `GOAL_TOLERANCE_RAD` of its end (`off-goal` otherwise, naming the joint).
- **Faults** (an aborted goal, a silent joint-state stream, a lost master, an
  e-stop) are recorded (`on_record`) with the robot's last joint state; the
  operator's `OnFault` choice then retries from the motion's start or stops the
  execution (`RobotStopped`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Literal

from app.execution.evidence import RobotMotion
from app.execution.robot_link import (
    GOAL_TOLERANCE_RAD,
    REFUSALS,
    Followed,
    GripperCommand,
    RobotFault,
    RobotLink,
    Side,
    Trajectory,
    arm_joints,
    farthest,
    off_goal,
)
from app.execution.timing import SPEED_RATIO, segment_seconds
from planner.plan.model import Motion
from planner.vocabulary import Action, Hold, Unhold

# The robot's joints this close to a motion's first waypoint (radians, each joint):
# it starts from where it is; farther, a planned motion takes it there first.
START_TOLERANCE_RAD = 0.05
# A trajectory's segments last at least this long: waypoints repeated in a path
# would otherwise share a time, which a trajectory controller refuses.
MIN_SEGMENT_S = 0.01
STATES_KEPT = 40  # joint states kept per motion in the session (thinned evenly)

FaultChoice = Literal["retry", "abort"]
# The operator's choice after a fault (the command line asks, the dashboard shows
# two buttons; without an operator: abort).
OnFault = Callable[[RobotFault], FaultChoice]
# A collision-free joint path of an arm from where it is to where a motion starts,
# or None when there is none.
ToStart = Callable[[str, list[float], list[float]], list[list[float]] | None]


class RobotStopped(Exception):
    """The operator stopped the execution after a robot fault (the fault's line)."""


def gripper_of(action: Action | None) -> GripperCommand | None:
    """The gripper command at the end of an actuation: a hold grips, an unhold releases."""
    if isinstance(action, Hold):
        return "grip"
    if isinstance(action, Unhold):
        return "release"
    return None


def timed(
    arm: str, joints: Sequence[str], path: Sequence[Sequence[float]], ratio: float = SPEED_RATIO
) -> Trajectory:
    """`path` as a trajectory: each segment as long as its slowest joint needs at
    `ratio` of Baxter's velocity limits."""
    if arm not in ("left", "right"):
        raise ValueError(f"no arm {arm!r}: Baxter has left and right")
    side: Side = "left" if arm == "left" else "right"
    times = [0.0]
    for seconds in segment_seconds(joints, path, ratio):
        times.append(times[-1] + max(seconds, MIN_SEGMENT_S))
    points = tuple(tuple(float(q) for q in p) for p in path)
    return Trajectory(side, tuple(joints), points, tuple(times))


def nearest(path: Sequence[Sequence[float]], here: Sequence[float], after: int = 0) -> int:
    """The index of the waypoint of `path` (from `after` on) closest to `here`."""
    return min(range(after, len(path)), key=lambda i: farthest(path[i], here))


def _thinned(
    samples: Sequence[tuple[float, tuple[float, ...]]],
) -> tuple[tuple[float, tuple[float, ...]], ...]:
    if len(samples) <= STATES_KEPT:
        return tuple(samples)
    step = (len(samples) - 1) / (STATES_KEPT - 1)
    return tuple(samples[round(i * step)] for i in range(STATES_KEPT))


def joined(goals: Sequence[Followed]) -> Followed:
    """The last of `goals` (one motion sent again after each pause) with the states of
    all, timed from the first goal sent."""
    last = goals[-1]
    first: float | None = None
    samples: list[tuple[float, tuple[float, ...]]] = []
    for goal in goals:
        if goal.began is None:  # refused before it was sent: no states
            continue
        first = goal.began if first is None else first
        samples.extend((round(t + goal.began - first, 3), q) for t, q in goal.samples)
    if len(goals) == 1 or first is None:
        return last
    return Followed(last.cause, last.detail, last.joints, tuple(samples), first)


def arrived(motion: Motion, followed: Followed) -> Followed:
    """`followed`, or an `off-goal` fault when the robot said it reached the end but a
    joint of its last state is farther from the motion's end than the tolerance."""
    if not followed.ok or not followed.joints:
        return followed
    off = off_goal(followed.joints, dict(zip(motion.joints, motion.path[-1], strict=True)))
    if off is None:
        return followed
    joint, error = off
    line = (
        f"the {motion.arm} arm stopped {abs(error):.3f} rad from the end of its motion at "
        f"{joint} (tolerance {GOAL_TOLERANCE_RAD} rad), though the robot said it arrived"
    )
    return Followed("off-goal", line, followed.joints, followed.samples, followed.began)


class RobotDriver:
    """Moves `link`'s robot along the plan's motions (see the module's text)."""

    def __init__(
        self,
        link: RobotLink,
        to_start: ToStart | None = None,
        on_fault: OnFault | None = None,
        speed_ratio: float = SPEED_RATIO,
    ) -> None:
        if not 0 < speed_ratio <= 1:
            raise ValueError(f"speed ratio {speed_ratio}: between 0 (excluded) and 1")
        self.link = link
        self.to_start = to_start
        self.on_fault = on_fault
        self.speed_ratio = speed_ratio
        self._cancelled = threading.Event()
        # Why the robot refused the last motion it was asked for (not enabled, stopped);
        # None when it took it.
        self.refused: RobotFault | None = None

    def cancel(self) -> None:
        """Stops the motion under way (Pause, Abort, the voice's "stop"): from any thread."""
        self._cancelled.set()
        self.link.cancel()

    def drive(
        self,
        motion: Motion,
        action: Action | None,
        gate: Callable[[], None],
        on_record: Callable[[RobotMotion], None],
    ) -> RobotMotion:
        """Runs `motion` to its end and says what the robot did. `gate` waits while the
        execution is paused (and raises when it is aborted); `on_record` keeps a fault."""
        gripper = gripper_of(action)
        resume_at = 0  # a pause cancelled the goal: the waypoint to go on from
        paused: list[Followed] = []  # the goals a pause cut short, this try's states
        while True:
            self._cancelled.clear()  # before the gate: a pause from here on is seen
            gate()
            followed, to_start = self._attempt(motion, gripper, resume_at)
            followed = arrived(motion, followed)
            if followed.cause == "preempted" and self._cancelled.is_set():
                paused.append(followed)
                here = arm_joints(followed.joints, motion.joints) if followed.joints else None
                resume_at = resume_at if here is None else nearest(motion.path, here, resume_at)
                continue
            followed = joined([*paused, followed])
            paused = []
            record = self._record(motion, followed, to_start)
            if followed.ok:
                return record
            on_record(record)
            fault = RobotFault(followed.cause or "aborted", followed.detail, followed.joints)
            choice = self.on_fault(fault) if self.on_fault is not None else "abort"
            if choice == "abort":
                raise RobotStopped(followed.detail)
            resume_at = 0  # after a fault the arm goes back to the motion's start

    def _attempt(
        self, motion: Motion, gripper: GripperCommand | None, resume_at: int
    ) -> tuple[Followed, bool]:
        """One try at `motion` from its waypoint `resume_at`: the report, and whether a
        motion to the start came first."""
        self.refused = None
        try:
            self.link.check_ready()
        except RobotFault as fault:
            self.refused = fault if fault.cause in REFUSALS else None
            return Followed(fault.cause, fault.line, fault.joints or self._last_joints()), False
        try:
            here = list(arm_joints(self.link.joints(), motion.joints))
            path, to_start = self._route(motion, here, resume_at)
            trajectory = timed(motion.arm, motion.joints, path, self.speed_ratio)
            return self.link.follow(trajectory, gripper), to_start
        except RobotFault as fault:
            return Followed(fault.cause, fault.line, fault.joints), False

    def _last_joints(self) -> dict[str, float]:
        try:
            return self.link.joints()
        except RobotFault:
            return {}

    def _route(
        self, motion: Motion, here: list[float], resume_at: int
    ) -> tuple[list[list[float]], bool]:
        """The path to send from `here`: the rest of the motion after a pause; else the
        motion itself, after a planned motion to its start when the arm is elsewhere."""
        rest = [list(p) for p in motion.path[resume_at + 1 :]] or [list(motion.path[-1])]
        if resume_at > 0:
            return [here, *rest], False
        start = list(motion.path[0])
        if farthest(here, start) <= START_TOLERANCE_RAD:
            return [here, *rest], False
        there = self.to_start(motion.arm, here, start) if self.to_start is not None else None
        if there is None:
            off = farthest(here, start)
            raise RobotFault(
                "off-start",
                f"the {motion.arm} arm is {off:.2f} rad from where the plan starts and "
                "no collision-free motion there was found",
                dict(zip(motion.joints, here, strict=True)),
            )
        return [*there, *rest], True

    def _record(self, motion: Motion, followed: Followed, to_start: bool) -> RobotMotion:
        reached: tuple[float, ...] = ()
        if followed.joints and all(j in followed.joints for j in motion.joints):
            reached = arm_joints(followed.joints, motion.joints)
        off = farthest(reached, motion.path[-1]) if reached else float("nan")
        return RobotMotion(
            link=self.link.name,
            arm=motion.arm,
            joints=tuple(motion.joints),
            reached=reached,
            off_rad=round(off, 5),
            states=_thinned(followed.samples),
            began=followed.began,
            to_start=to_start,
            cause=followed.cause,
            detail=None if followed.ok else followed.detail,
        )
