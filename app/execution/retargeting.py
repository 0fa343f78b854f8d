"""The motion planner behind an execution's re-targeting (see planner.feasibility.slot_map).

A `MotionRetargeter` answers the executor's `retarget` for a scenario checked by
geometry: the motion of the real action in the real state, through the same cached
checks as the plan's motions. It opens the check cache (and, on a cache miss, the
robot model) at its first question, in the thread that asks (the executor's:
SQLite connections stay in their thread), and the executor closes it there.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from planner.feasibility.scene import Site
from planner.plan.model import Motion, Plan
from planner.scenario.model import Scenario
from planner.vocabulary import Action

if TYPE_CHECKING:  # pybullet and OMPL load only when a motion is re-targeted
    from planner.feasibility.cache import CheckCache
    from planner.feasibility.checks import BenchChecks


class MotionRetargeter:
    """`app.execution.slots.Retarget` with the cached checks of `scenario`'s bench."""

    def __init__(self, scenario: Scenario, cache_dir: Path | str | None = None) -> None:
        self.scenario = scenario
        self.cache_dir = cache_dir
        self._cache: CheckCache | None = None
        self._checks: BenchChecks | None = None

    def motion(
        self, action: Action, state: list[str], real: Action, real_state: list[str]
    ) -> Motion | None:
        from planner.feasibility.plan_motions import retarget

        return retarget(action, state, real, real_state, self._open())

    def to_start(self, arm: str, here: list[float], start: list[float]) -> list[list[float]] | None:
        """A collision-free path of `arm` from `here` to `start` on the bench with its
        parts where the scenario puts them (`app.execution.robot_drive.ToStart`)."""
        return self._open().world.move(arm, here, start, frozenset())

    def reaches(self, arm: str, site: Site) -> bool:
        return self._open().reaches_site(arm, site)

    def _open(self) -> BenchChecks:
        if self._checks is None:
            from planner.feasibility.cache import CheckCache
            from planner.feasibility.checks import BenchChecks

            self._cache = CheckCache(self.cache_dir)
            self._checks = BenchChecks(self.scenario, cache=self._cache)
        return self._checks

    def close(self) -> None:
        if self._checks is not None:
            self._checks.close()
            self._checks = None
        if self._cache is not None:
            self._cache.close()
            self._cache = None


def retargeter_for(scenario: Scenario | None, plan: Plan) -> MotionRetargeter | None:
    """A retargeter when `plan` has motions and `scenario` (its own) is checked by
    geometry; None otherwise (nothing to re-target, or no bench to do it on)."""
    if scenario is None or scenario.feasibility.source != "geometry":
        return None
    if not any(node.motion for node in plan.nodes.values()):
        return None
    return MotionRetargeter(scenario)
