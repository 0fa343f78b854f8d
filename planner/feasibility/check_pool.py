"""World queries answered by worker processes, each with its own pybullet client.

IK and OMPL hold the GIL, so threads give no speed-up: each process opens its
own `World` (a DIRECT client made after the fork) on first use. Every query
reseeds its random numbers from its own arguments (`World.check_reach`,
`World.move`), so an answer does not depend on which process gave it or what it
answered before.
"""

from __future__ import annotations

import multiprocessing as mp
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any

from planner.feasibility.reach import ReachResult, World
from planner.scenario_model import Scenario

Config = list[float]

_world: World | None = None
_setup: tuple[Scenario, dict[str, Any]] | None = None


def _init(scenario: Scenario, options: dict[str, Any]) -> None:
    global _setup, _world
    _setup, _world = (scenario, options), None


def _own_world() -> World:
    global _world
    if _world is None:
        assert _setup is not None
        scenario, options = _setup
        _world = World(scenario, **options)
    return _world


def _reach(arm: str, part: str) -> ReachResult:
    return _own_world().check_reach(arm, part)


def _move(arm: str, start: Config, goal: Config, parts: frozenset[str]) -> list[Config] | None:
    return _own_world().move(arm, start, goal, parts)


def _warm_up() -> bool:
    _own_world()
    return True


class CheckPool:
    """`workers` processes answering `World.check_reach` and `World.move` queries."""

    def __init__(self, scenario: Scenario, options: dict[str, Any], workers: int) -> None:
        self._pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=mp.get_context("fork"),
            initializer=_init,
            initargs=(scenario, options),
        )
        # Every process loads the robot at once, while the first answers are awaited.
        for _ in range(workers):
            self._pool.submit(_warm_up)

    def reach(self, arm: str, part: str) -> Future[ReachResult]:
        return self._pool.submit(_reach, arm, part)

    def move(
        self, arm: str, start: Config, goal: Config, parts: frozenset[str]
    ) -> Future[list[Config] | None]:
        return self._pool.submit(_move, arm, start, goal, parts)

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)
