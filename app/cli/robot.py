"""`tandem robot sim`: a simulated Baxter on ROS 1, for `tandem execute --robot ros`.

The node (`app.robot.sim_node`) serves Baxter's joint states, endpoint states,
robot state (enable, stop, reset, e-stop), trajectory actions and grippers on
the master given with `--master` (default `$ROS_MASTER_URI`). It needs ROS 1
(`make robot`); a missing ROS or master is one line and exit code 2. It runs
until Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import json
import os
from typing import Literal

from app.cli.exit_codes import BadInput
from app.robot.sim_gripper import GripperKind  # no ROS nor pybullet: only the kinds

DEFAULT_MASTER = "http://localhost:11311"  # ROS 1's own default
ArmSide = Literal["left", "right"]
ARM_SIDES: tuple[ArmSide, ArmSide] = ("left", "right")


def register(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="robot_command", metavar="ACTION")
    sim = sub.add_parser(
        "sim",
        help="a simulated Baxter: joint states, trajectory actions, grippers",
        description="Serve Baxter's ROS 1 interface on a simulated (pybullet) Baxter.",
    )
    sim.add_argument(
        "--master",
        metavar="URI",
        help=f"the ROS master (default $ROS_MASTER_URI, else {DEFAULT_MASTER})",
    )
    sim.add_argument(
        "--rate",
        type=float,
        default=100.0,
        metavar="HZ",
        help="joint states per second (default 100)",
    )
    sim.add_argument(
        "--start",
        default="home",
        metavar="JSON|home",
        help="where the arms start: home (the plan's start; the default) or joints in radians, "
        "e.g. '{\"left_s0\": 0.3}' (the others at home)",
    )
    sim.add_argument(
        "--enabled",
        choices=["yes", "no"],
        default="yes",
        help="whether the robot starts enabled (default yes; no: as Baxter boots, "
        "disabled until /robot/set_super_enable)",
    )
    sim.add_argument(
        "--gripper",
        action="append",
        default=[],
        metavar="KIND|SIDE=KIND",
        help="the grippers: electric (the default) or suction, for both sides or one "
        "(e.g. --gripper right=suction); repeatable",
    )
    sim.add_argument(
        "--gui", choices=["no", "yes"], default="no", help="show pybullet's window (default no)"
    )
    sim.set_defaults(run=run_sim_command)


def start_joints(text: str) -> dict[str, float] | None:
    """`--start`'s joints (None: home)."""
    if text == "home":
        return None
    from app.robot.sim_model import ARM_JOINTS

    try:
        joints = json.loads(text)
    except json.JSONDecodeError as err:
        raise BadInput(f"--start: not JSON nor home: {err}") from err
    if not isinstance(joints, dict) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in joints.values()
    ):
        raise BadInput('--start: expected an object of joint names and radians, {"left_s0": 0.3}')
    unknown = sorted(set(joints) - set(ARM_JOINTS))
    if unknown:
        raise BadInput(f"--start: not arm joints: {', '.join(unknown)}")
    return {name: float(value) for name, value in joints.items()}


def gripper_kinds(values: list[str]) -> dict[ArmSide, GripperKind]:
    """`--gripper`'s kinds per side (both electric unless said)."""
    kinds: dict[ArmSide, GripperKind] = {"left": "electric", "right": "electric"}
    for value in values:
        side, _, name = value.rpartition("=")
        if name not in ("electric", "suction"):
            raise BadInput(f"--gripper {value}: the kind is electric or suction")
        if side not in ("", "left", "right"):
            raise BadInput(f"--gripper {value}: the side is left or right")
        kind: GripperKind = "suction" if name == "suction" else "electric"
        for each in ARM_SIDES:
            if side in ("", each):
                kinds[each] = kind
    return kinds


def run_sim_command(args: argparse.Namespace) -> int:
    if args.rate <= 0:
        raise BadInput(f"--rate {args.rate}: must be positive")
    start = start_joints(args.start)
    grippers = gripper_kinds(args.gripper)
    master = args.master or os.environ.get("ROS_MASTER_URI") or DEFAULT_MASTER
    # ROS and pybullet load only for this command.
    from app.robot.ros_env import RosMissing
    from app.robot.sim_model import StartBeyondLimits
    from app.robot.sim_node import NoMaster, SimSettings, run_sim

    try:
        settings = SimSettings(
            master,
            args.rate,
            start,
            args.gui == "yes",
            enabled=args.enabled == "yes",
            grippers=grippers,
        )
        return run_sim(settings)
    except (RosMissing, NoMaster, StartBeyondLimits) as err:
        raise BadInput(str(err)) from err
