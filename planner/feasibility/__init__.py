"""Geometric feasibility: which Baxter arm can reach which part (pybullet + OMPL).

`reachability_table(scenario)` answers every (manipulator, part) pair with a
`ReachResult`; its reachable pairs can replace the declared feasibility table
(`Scenario.facts(reachable=...)`, the ASP `@reachable(M,P)` external).
"""

from __future__ import annotations

from planner.feasibility.reach import PlannerName, ReachResult, Reason, World
from planner.feasibility.robot import ARMS
from planner.scenario_model import Scenario

__all__ = ["ReachResult", "Reason", "World", "reachability_table", "reachable_pairs"]


def reachability_table(
    scenario: Scenario,
    *,
    planner: PlannerName = "RRTConnect",
    time_limit: float = 1.0,
    seed: int = 0,
) -> dict[tuple[str, str], ReachResult]:
    """Every (arm, part) pair, in file order: movable parts and the top alike.

    Only manipulators named like Baxter's arms ("left", "right") have a geometric
    model; any other name is a scenario this module cannot answer for.
    """
    unknown = [m for m in scenario.robot.manipulators if m not in ARMS]
    if unknown:
        raise ValueError(f"no geometric model for manipulators {unknown}: expected {ARMS}")
    table: dict[tuple[str, str], ReachResult] = {}
    with World(scenario, planner=planner, time_limit=time_limit, seed=seed) as world:
        for arm in scenario.robot.manipulators:
            for part in scenario.parts:
                table[(arm, part.id)] = world.check_reach(arm, part.id)
    return table


def reachable_pairs(table: dict[tuple[str, str], ReachResult]) -> set[tuple[str, str]]:
    return {pair for pair, result in table.items() if result.reachable}
