"""Geometric feasibility: which Baxter arm can reach which part (pybullet + OMPL).

`reachability_table(scenario)` answers every (manipulator, part) pair with a
`ReachResult`; its reachable pairs can replace the declared feasibility table
(`Scenario.facts(reachable=...)`, the ASP `@reachable(M,P)` external).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from planner.feasibility.cache import CheckCache
    from planner.feasibility.checks import BenchChecks
    from planner.feasibility.reach import PlannerName, ReachResult, Reason, World
    from planner.scenario.model import Scenario

# Loaded on first use: `planner.feasibility.arms` and `.scene` are plain data that
# the dashboard reads without loading pybullet and OMPL.
_LAZY = {
    "BenchChecks": "planner.feasibility.checks",
    "CheckCache": "planner.feasibility.cache",
    "ReachResult": "planner.feasibility.reach",
    "Reason": "planner.feasibility.reach",
    "World": "planner.feasibility.reach",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "BenchChecks",
    "CheckCache",
    "ReachResult",
    "Reason",
    "World",
    "reachability_table",
    "reachable_pairs",
]


def reachability_table(
    scenario: Scenario,
    *,
    planner: PlannerName = "RRTConnect",
    time_limit: float = 1.0,
    seed: int = 0,
    cache: CheckCache | None = None,
) -> dict[tuple[str, str], ReachResult]:
    """Every (arm, part) pair, in file order, from `cache` where it has them."""
    from planner.feasibility.checks import BenchChecks

    with BenchChecks(
        scenario, planner=planner, time_limit=time_limit, seed=seed, cache=cache
    ) as checks:
        return checks.table()


def reachable_pairs(table: dict[tuple[str, str], ReachResult]) -> set[tuple[str, str]]:
    return {pair for pair, result in table.items() if result.reachable}
