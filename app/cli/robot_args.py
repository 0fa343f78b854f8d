"""`--robot` and `--speed-ratio` of `tandem execute`: which robot makes the motions.

`drawing` (the default) only draws them; `ros[:MASTER_URI]` drives Baxter (or
`tandem robot sim`) over ROS 1 through `app.robot.ros_link`. The link is
reached before the session starts, so a missing master or action server is one
line and exit code 2, and no session is stored for a run that never began.
The node's address for the robot is printed once connected (`ROS_IP` or
`ROS_HOSTNAME` as set, as rospy takes them). A robot that is not enabled refuses
the first motion: the session is stored with the refusal, and the run ends
with exit code 2 (the operator must act on the robot), unless `--enable`
enabled it when connecting (as Rethink's `enable_robot.py -e` does). After a
fault the operator chooses: on a terminal the command asks "retry or abort";
without one it aborts.
"""

from __future__ import annotations

import argparse
import sys

from app.cli.exit_codes import BadInput
from app.execution.robot_drive import FaultChoice, RobotDriver, ToStart
from app.execution.robot_link import RobotFault, RobotLink
from app.execution.timing import SPEED_RATIO

CONNECT_TIMEOUT_S = 5.0


def register_robot_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--robot",
        default="drawing",
        metavar="drawing|ros[:MASTER_URI]",
        help="who makes the motions: drawing (nobody; the default) or ros (Baxter's ROS 1 "
        "interface at MASTER_URI, default $ROS_MASTER_URI; `tandem robot sim` serves it)",
    )
    parser.add_argument(
        "--enable",
        action="store_true",
        help="with --robot ros, enable the robot when connecting (reset first if it was "
        "stopped and its e-stop is released); without it a disabled robot refuses to move",
    )
    parser.add_argument(
        "--speed-ratio",
        type=float,
        default=SPEED_RATIO,
        help=f"with --robot ros, the share of Baxter's joint velocity limits the arms move at "
        f"(default {SPEED_RATIO}, baxter_interface's)",
    )


def robot_link(spec: str, enable: bool = False) -> RobotLink | None:
    """The link `spec` names, not connected yet (None: the drawing); `enable`: it
    enables the robot when it connects."""
    if spec == "drawing":
        if enable:
            raise BadInput("--enable goes with --robot ros")
        return None
    if spec == "ros" or spec.startswith("ros:"):
        from app.robot.ros_link import RosLink  # ROS only when it is chosen

        return RosLink(spec[len("ros:") :] or None, enable)
    raise BadInput(f"--robot {spec}: expected drawing or ros[:MASTER_URI]")


def robot_from_args(args: argparse.Namespace, to_start: ToStart | None) -> RobotDriver | None:
    """The connected robot of `--robot`, or None; a robot it cannot reach is BadInput.
    `to_start` plans the motions to where the plan starts (None: none can be made)."""
    if not 0 < args.speed_ratio <= 1:
        raise BadInput(f"--speed-ratio {args.speed_ratio}: between 0 (excluded) and 1")
    link = robot_link(args.robot, args.enable)
    if link is None:
        return None
    from app.robot.ros_env import RosMissing

    try:
        link.connect(CONNECT_TIMEOUT_S)
    except (RobotFault, RosMissing) as err:
        raise BadInput(f"--robot {args.robot}: {err}") from err
    print(link.advertised(), flush=True)
    return RobotDriver(link, to_start, ask_operator, args.speed_ratio)


def ask_operator(fault: RobotFault) -> FaultChoice:
    """The operator's choice after `fault`: asked on a terminal, else abort."""
    print(f"robot: {fault.line}", file=sys.stderr, flush=True)
    if not sys.stdin.isatty():
        return "abort"
    while True:
        answer = input("retry or abort? [r/a] ").strip().lower()
        if answer in ("r", "retry"):
            return "retry"
        if answer in ("a", "abort", ""):
            return "abort"
