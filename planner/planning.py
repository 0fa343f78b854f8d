"""From a scenario to a checked `tandem-plan/1` document: the planning pipeline."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from planner.hcp import ConditionalPlanner, DagNode, Problem, Progress
from planner.plan import Plan, build_plan
from planner.scenario import Scenario
from planner.solver import State

# Steps per milestone solve; a milestone that needs more is retried with 2x, 4x, 8x.
# Short horizons keep solves at a few milliseconds (paper-05: 1.7 s at 4, 5.0 s at 8).
DEFAULT_HORIZON = 4


class PlanningCancelled(Exception):
    """Planning was cancelled before every branch was planned."""


@dataclass
class PlanResult:
    plan: Plan
    first_branch_s: float  # when the first complete, executable branch existed
    solves: int


def initial_state(scenario: Scenario) -> State:
    """Nothing held or attached; the human's hands are unknown unless they can pick nothing up."""
    human_regions = {r.id for r in scenario.regions if r.human_reach}
    can_pick = scenario.human.initiative > 0 and any(
        p.movable and p.region in human_regions for p in scenario.parts
    )
    return frozenset() if can_pick else frozenset({"humanFree"})


def feasible_pairs(scenario: Scenario) -> tuple[frozenset[tuple[str, str]], float]:
    """(arm, part) pairs the robot can reach, and the seconds spent checking them.

    Declared scenarios answer from their table; geometric ones ask the motion
    planner once per pair, in the parent process, so workers share the answers.
    """
    if scenario.feasibility.source != "geometry":
        return frozenset(scenario.reachable_pairs()), 0.0
    # Imported here: pybullet and OMPL load only when geometry is asked for.
    from planner.feasibility import reachability_table, reachable_pairs

    t0 = time.perf_counter()
    table = reachability_table(scenario)
    return frozenset(reachable_pairs(table)), time.perf_counter() - t0


def plan_scenario(
    scenario: Scenario,
    *,
    workers: int = 0,
    progress: Callable[[Progress], None] | None = None,
    planner_hook: Callable[[ConditionalPlanner], None] | None = None,
    skip: tuple[str, ...] = (),
) -> PlanResult:
    """Plans every contingency of `scenario`; raises `hcp.DeadEnd` if no plan exists.

    `planner_hook` receives the planner before it starts (to cancel it from
    another thread); `skip` leaves encoding concerns out (for ablation tests).
    """
    t0 = time.perf_counter()
    reachable, checks_s = feasible_pairs(scenario)
    facts = scenario.facts(reachable)
    problem = Problem(
        facts=tuple(f for f in facts if not f.startswith("reachable(")),
        reachable=reachable,
        horizon=DEFAULT_HORIZON,
        skip=skip,
    )
    first: list[float] = []

    def on_first(_: dict[State, DagNode]) -> None:
        first.append(time.perf_counter() - t0)

    planner = ConditionalPlanner(
        problem, scenario.goal_pairs(), workers=workers, progress=progress, on_first_branch=on_first
    )
    if planner_hook:
        planner_hook(planner)
    root = planner.build(initial_state(scenario))
    if planner.cancelled:
        raise PlanningCancelled(f"cancelled after {planner.solves} solves")
    plan_s = time.perf_counter() - t0
    plan = build_plan(
        planner.nodes,
        root,
        scenario_name=scenario.name,
        scenario_sha256=scenario.sha256,
        facts=facts,
        plan_s=plan_s,
        checks_s=checks_s,
    )
    return PlanResult(plan, first[0] if first else plan_s, planner.solves)
