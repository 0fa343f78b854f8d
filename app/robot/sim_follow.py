"""How the simulated trajectory action server follows a goal and judges its end, as
Rethink's joint trajectory action server (baxter_interface 1.2.0, position
mode) does:

- tolerances: a goal's `path_tolerance` and `goal_tolerance` entries replace the
  server's defaults for the joints they name (a position of 0 keeps the
  default); `goal_time_tolerance` of 0 keeps its default. The defaults are the
  server's: path 0.2 rad, goal -1 (unchecked), goal time 0.1 s, stopped
  velocity 0.25 rad/s;
- while the robot is enabled it commands the spline (`app.robot.sim_spline`)
  each tick; before each command it compares where the joints are with the
  point about to be commanded, and an error of the path tolerance or more
  aborts the goal (PATH_TOLERANCE_VIOLATED; a negative tolerance is unchecked).
  Here the arm is kinematic, so that error is one tick's step, or a stall;
- after the last point it keeps commanding it for the goal time tolerance (on
  every goal: the result comes that much after the trajectory's end), then
  checks the goal: a joint off its last point by more than a positive goal
  tolerance, or a joint still faster than the stopped velocity, is
  GOAL_TOLERANCE_VIOLATED (aborted); otherwise SUCCEEDED;
- a disabled or stopped robot (disabled, the software stop, the e-stop) ends
  the commanding at once and goes straight to the goal check: the arm halts
  where it is, and with the default goal tolerance (unchecked) the goal
  SUCCEEDS though the arm never arrived. Only a goal with goal tolerances is
  aborted. On a robot disabled from the start the goal succeeds without moving.
  This is the real server's behaviour, kept so that a client's own checks are
  what catch it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

DEFAULT_PATH_TOLERANCE = 0.2  # rad, per joint
DEFAULT_GOAL_TOLERANCE = -1.0  # rad: not checked
DEFAULT_GOAL_TIME = 0.1  # s
STOPPED_VELOCITY = 0.25  # rad/s at the goal check


@dataclass(frozen=True)
class Tolerances:
    """One goal's tolerances, per joint (rad) and its goal time (s)."""

    path: Mapping[str, float]
    goal: Mapping[str, float]
    goal_time: float
    stopped_velocity: float = STOPPED_VELOCITY


def tolerances(
    joints: Sequence[str],
    path: Sequence[tuple[str, float]],
    goal: Sequence[tuple[str, float]],
    goal_time_s: float,
) -> Tolerances:
    """The tolerances for `joints` from a goal's (joint, position tolerance) lists
    and goal time tolerance, over the server's defaults."""

    def per_joint(given: Sequence[tuple[str, float]], default: float) -> dict[str, float]:
        named = {name: value for name, value in given if value != 0.0}
        return {name: named.get(name, default) for name in joints}

    return Tolerances(
        path=per_joint(path, DEFAULT_PATH_TOLERANCE),
        goal=per_joint(goal, DEFAULT_GOAL_TOLERANCE),
        goal_time=goal_time_s if goal_time_s != 0.0 else DEFAULT_GOAL_TIME,
    )


def path_error(
    tolerances: Tolerances, where: Mapping[str, float], command: Mapping[str, float]
) -> tuple[str, float] | None:
    """The first joint whose error reaches its path tolerance, and the error."""
    for name, target in command.items():
        error = target - where[name]
        limit = tolerances.path[name]
        if limit >= 0.0 and abs(error) >= limit:
            return name, error
    return None


def goal_error(
    tolerances: Tolerances,
    where: Mapping[str, float],
    velocity: Mapping[str, float],
    last: Mapping[str, float],
) -> str | None:
    """Why the goal is not met (None: it is)."""
    for name, target in last.items():
        error = target - where[name]
        limit = tolerances.goal[name]
        if limit > 0.0 and abs(error) > limit:
            return f"{name} is {error:+.4f} rad from its goal, over its tolerance of {limit:.4f}"
    fastest = max((abs(velocity[name]) for name in last), default=0.0)
    if tolerances.stopped_velocity > 0.0 and fastest > tolerances.stopped_velocity:
        return f"a joint still moves at {fastest:.3f} rad/s at the goal"
    return None


def stalled_joint(start: Mapping[str, float], last: Mapping[str, float]) -> str | None:
    """The joint a stall holds back: the one that travels farthest (None: none moves)."""
    name = max(last, key=lambda n: abs(last[n] - start[n]), default=None)
    return name if name is not None and last[name] != start[name] else None


def stall(
    command: float, start: float, last: float, short_rad: float
) -> float:  # fmt: skip
    """A stalled joint's position: no farther towards `last` than `short_rad` short
    of it, nor back behind `start`."""
    if last >= start:
        return max(start, min(command, last - short_rad))
    return min(start, max(command, last + short_rad))
