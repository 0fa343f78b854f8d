"""Feasibility checks of one bench, answered from the cache or the motion planner.

`BenchChecks` opens a pybullet `World` only on the first cache miss, so a plan
whose checks are all cached loads neither the robot nor OMPL's planners.
"""

from __future__ import annotations

from typing import Any

from planner.feasibility.arms import ARMS, HOME
from planner.feasibility.cache import CheckCache, geometry_key
from planner.feasibility.reach import PlannerName, ReachResult, World
from planner.scenario_model import Scenario

Config = list[float]


class BenchChecks:
    """Reachability and arm motions on one scenario's bench."""

    def __init__(
        self,
        scenario: Scenario,
        *,
        planner: PlannerName = "RRTConnect",
        time_limit: float = 1.0,
        seed: int = 0,
        cache: CheckCache | None = None,
    ) -> None:
        unknown = [m for m in scenario.robot.manipulators if m not in ARMS]
        if unknown:
            raise ValueError(f"no geometric model for manipulators {unknown}: expected {ARMS}")
        self.scenario = scenario
        self._options: dict[str, Any] = {"planner": planner, "time_limit": time_limit, "seed": seed}
        self.cache = cache if cache is not None else CheckCache(":memory:")
        self.key = geometry_key(scenario, **self._options)
        self._world: World | None = None
        self._reach: dict[tuple[str, str], ReachResult] = {}

    @property
    def world(self) -> World:
        if self._world is None:
            self._world = World(self.scenario, **self._options)
        return self._world

    def close(self) -> None:
        if self._world is not None:
            self._world.close()
            self._world = None

    def __enter__(self) -> BenchChecks:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def reach(self, arm: str, part: str) -> ReachResult:
        """Can `arm` reach `part` from home (its work point: docs/scenario.md)?"""
        if (arm, part) in self._reach:
            return self._reach[(arm, part)]
        key = f"{self.key}/reach/{arm}/{part}"
        stored = self.cache.get(key)
        if stored is not None:
            result = ReachResult(**stored)
        else:
            result = self.world.check_reach(arm, part)
            self.cache.put(key, result.__dict__)
        self._reach[(arm, part)] = result
        return result

    def table(self) -> dict[tuple[str, str], ReachResult]:
        """Every (arm, part) pair, in file order: movable parts and the top alike."""
        return {
            (arm, part.id): self.reach(arm, part.id)
            for arm in self.scenario.robot.manipulators
            for part in self.scenario.parts
        }

    def at(self, arm: str, part: str | None) -> Config:
        """Where `arm` stands when working on `part` (None: home)."""
        if part is None:
            return list(HOME[arm])
        return self._reach_path(arm, part)[-1]

    def move(self, arm: str, start: str | None, goal: str | None) -> list[Config]:
        """A collision-free path of `arm` from its work point on `start` to the one on
        `goal` (None: home). Paths to and from home are the reach paths; between two
        parts the motion planner is asked, and if it finds nothing the arm goes by home."""
        if start == goal:
            return [self.at(arm, start)]
        if start is None:
            assert goal is not None  # both None returned above
            return self._reach_path(arm, goal)
        if goal is None:
            return self._reach_path(arm, start)[::-1]
        key = f"{self.key}/move/{arm}/{start}/{goal}"
        stored = self.cache.get(key)
        if stored is not None:
            return list(stored)
        direct = self.world.move(
            arm, self.at(arm, start), self.at(arm, goal), frozenset({start, goal})
        )
        path = direct or self._reach_path(arm, start)[::-1] + self._reach_path(arm, goal)[1:]
        self.cache.put(key, path)
        return path

    def _reach_path(self, arm: str, part: str) -> list[Config]:
        path = self.reach(arm, part).path
        if path is None:
            raise ValueError(f"{arm} cannot reach {part}")
        return path
