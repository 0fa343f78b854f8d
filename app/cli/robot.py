"""`tandem robot sim`: a simulated Baxter on ROS 1, for `tandem execute --robot ros`.

The node (`app.robot.sim_node`) serves Baxter's joint states, trajectory
actions and grippers on the master given with `--master` (default
`$ROS_MASTER_URI`). It needs ROS 1 (`make robot`); a missing ROS or master is
one line and exit code 2. It runs until Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import json
import os

from app.cli.exit_codes import BadInput

DEFAULT_MASTER = "http://localhost:11311"  # ROS 1's own default


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


def run_sim_command(args: argparse.Namespace) -> int:
    if args.rate <= 0:
        raise BadInput(f"--rate {args.rate}: must be positive")
    start = start_joints(args.start)
    master = args.master or os.environ.get("ROS_MASTER_URI") or DEFAULT_MASTER
    # ROS and pybullet load only for this command.
    from app.robot.ros_env import RosMissing
    from app.robot.sim_model import StartBeyondLimits
    from app.robot.sim_node import NoMaster, SimSettings, run_sim

    try:
        return run_sim(SimSettings(master, args.rate, start, args.gui == "yes"))
    except (RosMissing, NoMaster, StartBeyondLimits) as err:
        raise BadInput(str(err)) from err
