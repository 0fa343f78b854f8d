"""`tandem feasibility SCENARIO`: which arm reaches which part, by geometry."""

from __future__ import annotations

import argparse
import time

from app.cli.exit_codes import BadInput
from planner.plan.model import format_table
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", help="scenario file (TOML)")
    parser.add_argument(
        "--planner", choices=["RRTConnect", "RRTstar"], default="RRTConnect", help="OMPL planner"
    )
    parser.add_argument(
        "--time-limit", type=float, default=1.0, help="seconds per path query (default 1)"
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (IK restarts, OMPL)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    scenario = load_scenario(find_scenario(args.scenario))
    # Imported here so the other subcommands never pay for pybullet and OMPL.
    from planner.feasibility import reachability_table
    from planner.feasibility.robot import RobotModelMissing

    start = time.perf_counter()
    try:
        table = reachability_table(
            scenario, planner=args.planner, time_limit=args.time_limit, seed=args.seed
        )
    except (RobotModelMissing, ValueError) as err:
        # Caught here, not in main's table: naming RobotModelMissing there would
        # load pybullet for every subcommand.
        raise BadInput(f"{args.scenario}: feasibility: {err}") from err
    total = time.perf_counter() - start
    rows: list[tuple[str, ...]] = [
        (
            arm,
            part,
            scenario.part(part).region,
            "yes" if r.reachable else "no",
            r.reason,
            f"{r.seconds:.3f}",
        )
        for (arm, part), r in table.items()
    ]
    header = ("manipulator", "part", "region", "reachable", "reason", "seconds")
    print(format_table(header, rows))
    print(f"{scenario.name}: {len(table)} checks in {total:.2f} s")
    return 0
