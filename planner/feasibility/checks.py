"""Feasibility checks of one bench, answered from the cache or the motion planner.

`BenchChecks` opens a pybullet `World` (or, with `workers` > 1, a `CheckPool` of
processes) only on the first cache miss, so a plan whose checks are all cached
loads neither the robot nor OMPL's planners. `answers` and `prefetch_moves` ask
for many answers at once, so the pool works on them side by side; the IK of all
the pairs `answers` asks about is solved first, in one pass per arm (`grasp_ik`;
in the pool's processes if there is a pool), which answers those out of reach
at once. `answers` returns as soon as every pair is decided: the paths (needed
only for the plan's motions) are simplified meanwhile, and reach the cache when
first asked for or when the checks close.

A motion goes between places: a part id (its work point, as reachability checks
it) or a `Site` (a connection point where the state puts it: scene.py). Sites are
reached from this process's world; part-to-part and site motions use the pool.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future
from typing import Any

from planner.feasibility.arms import ARMS, HOME
from planner.feasibility.cache import CheckCache, geometry_key
from planner.feasibility.check_pool import CheckPool, Pair, question
from planner.feasibility.grasp_ik import IkAnswers
from planner.feasibility.reach import PlannerName, ReachResult, Reason, World
from planner.feasibility.scene import Site
from planner.scenario.model import Scenario

Config = list[float]
Place = str | Site  # a part's work point, or a connection point's site
Move = tuple[str, Place, Place]  # arm, from, to (neither home)


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
        workers: int = 1,
    ) -> None:
        unknown = [m for m in scenario.robot.manipulators if m not in ARMS]
        if unknown:
            raise ValueError(f"no geometric model for manipulators {unknown}: expected {ARMS}")
        self.scenario = scenario
        self._options: dict[str, Any] = {"planner": planner, "time_limit": time_limit, "seed": seed}
        self.cache = cache if cache is not None else CheckCache(":memory:")
        self.key = geometry_key(scenario, **self._options)
        self._world: World | None = None
        self._workers = workers
        self._pool: CheckPool | None = None
        self._reach: dict[Pair, ReachResult] = {}
        self._site_reach: dict[tuple[str, Site], ReachResult] = {}
        # Decided in the pool, their paths still being made by `_batches`.
        self._decided: dict[Pair, tuple[bool, Reason]] = {}
        # Where an arm stands at a place decided in the pool, before its path is made.
        self._goals: dict[Pair, Config] = {}
        self._batches: list[Future[dict[Pair, ReachResult]]] = []
        self._move_pending: dict[Move, Future[list[Config] | None]] = {}
        self._site_pending: dict[tuple[str, Site], Future[ReachResult]] = {}

    @property
    def world(self) -> World:
        if self._world is None:
            self._world = World(self.scenario, **self._options)
        return self._world

    @property
    def parallel(self) -> bool:
        """Whether checks may run in a pool of processes (`prefetch_*` start them there)."""
        return self._workers > 1

    @property
    def pool(self) -> CheckPool | None:
        """The worker processes (None with one worker), started on first need."""
        if self._pool is None and self._workers > 1:
            self._pool = CheckPool(self.scenario, self._options, self._workers)
        return self._pool

    def close(self) -> None:
        if self._batches:
            self._collect()  # every answer into the cache, paths and all
        if self._world is not None:
            self._world.close()
            self._world = None
        if self._pool is not None:
            self._pool.close()
            self._pool = None

    def __enter__(self) -> BenchChecks:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def reach(self, arm: str, part: str) -> ReachResult:
        """Can `arm` reach `part` from home (its work point: docs/scenario.md), and how?"""
        if (arm, part) in self._decided:
            self._collect()
        result = self._reach.get((arm, part))
        if result is None:
            stored = self.cache.get(self._reach_key(arm, part))
            result = None if stored is None else ReachResult(**stored)
        if result is None or result.path_missing:
            # Never checked, or answered without its path (a fixed part's, made by the
            # pool only on demand): the check again, reseeded as it was, gives the path.
            result = self.world.check_reach(arm, part)
            self.cache.put(self._reach_key(arm, part), result.__dict__)
        self._reach[(arm, part)] = result
        return result

    def answers(self, hope: Callable[[dict[Pair, bool]], None] | None = None) -> dict[Pair, bool]:
        """Whether each arm reaches each part (every pair, in file order), without
        waiting for the paths of the pool's checks. The points of fixed parts
        (`point_answers`) are decided in the same batch.

        `hope` is told, while the pool checks paths, the answers hoped for: every
        pair (points too, as Site texts) with an IK answer that meets its grasp
        counted reachable (on the paper's benches, every one is), so that what
        follows from them can start (`branch_planner.ground_ahead`)."""
        pairs = self.pairs()
        points = [(arm, str(site)) for arm, site in self.point_sites()]
        todo = []
        for arm, target in pairs + points:
            if (arm, target) in self._decided or self._known(arm, target):
                continue
            todo.append((arm, target))
        if todo:
            self._decide(todo, pairs + points, hope)
        return {pair: self._answer(*pair) for pair in pairs}

    def _decide(
        self, todo: list[Pair], every: list[Pair], hope: Callable[[dict[Pair, bool]], None] | None
    ) -> None:
        """Decides the reach of `todo`: the IK of their first seed batches in
        passes over many of them (`GraspIk.first_batches`), "no IK" at once, the
        others in the pool side by side as soon as their IK is known (or all of it
        in this process's world)."""
        pool = self.pool
        by_question = {question(pair): pair for pair in todo}
        asked: list[Pair] = []

        start = time.perf_counter()
        solved = (self.world.ik if pool is None else pool).first_batches(by_question)

        def kinematic() -> Iterator[tuple[Pair, IkAnswers]]:
            for count, (q, given) in enumerate(solved, 1):
                pair = by_question[q]
                if given is None:
                    seconds = (time.perf_counter() - start) / count
                    self._keep(pair, ReachResult(False, "no IK", seconds, None))
                else:
                    asked.append(pair)
                    yield pair, given

        if pool is None:
            for pair, given in kinematic():
                q = question(pair)
                decision = self.world.decide_reach(q.arm, q.part, q.point, ik=given)
                self._keep(pair, self.world.finish_reach(decision))
            return
        batches = pool.decide(kinematic())
        self._batches.extend(batches)
        if hope is not None:  # the IK is done: the pairs asked are in the pool
            hoped = set(asked)
            hope({p: p in hoped or self._answer(*p) for p in every})
        for pair, reachable, reason, goal in pool.decisions(len(asked), batches):
            self._decided[pair] = (reachable, reason)
            if goal is not None:
                self._goals[pair] = goal

    def _keep(self, pair: Pair, result: ReachResult) -> None:
        """A reach answer of a part or a site (`Pair`), kept and cached."""
        self.cache.put(self._reach_key(*pair), result.__dict__)
        site = Site.parse(pair[1])
        if site is None:
            self._reach[pair] = result
        else:
            self._site_reach[(pair[0], site)] = result

    def point_sites(self) -> list[tuple[str, Site]]:
        """Every (arm, point of a fixed part) pair, in file order: where an attachment
        onto the top lands, and where whatever is attached there stands."""
        if self.scenario.feasibility.points != "each":
            return []  # the top is reached by its nearest point (scene.PartBox.work_point)
        arms = self.scenario.robot.manipulators
        fixed = [p for p in self.scenario.parts if not p.movable and p.connection_points]
        return [(arm, Site(p.id, c)) for arm in arms for p in fixed for c in p.connection_points]

    def point_answers(self) -> dict[tuple[str, Site], bool]:
        """Whether each arm reaches each point of a fixed part (decided with `answers`)."""
        self.answers()
        return {(arm, site): self._answer(arm, str(site)) for arm, site in self.point_sites()}

    def _known(self, arm: str, target: str) -> bool:
        """Whether the answer for `target` (a part id or a Site's text) is at hand or
        cached; a cached one is kept."""
        site = Site.parse(target)
        if site is not None:
            return self.site_known(arm, site)
        if (arm, target) in self._reach:
            return True
        stored = self.cache.get(self._reach_key(arm, target))
        if stored is not None:
            self._reach[(arm, target)] = ReachResult(**stored)
        return stored is not None

    def _answer(self, arm: str, target: str) -> bool:
        if (arm, target) in self._decided:
            return self._decided[(arm, target)][0]
        site = Site.parse(target)
        if site is not None:
            return self.reach_site(arm, site).reachable
        # Known or cached: its answer, even where its path is missing; else checked.
        known = self._reach[(arm, target)] if self._known(arm, target) else None
        return (known or self.reach(arm, target)).reachable

    def release_paths(self) -> None:
        """The pool may now simplify the paths of the answers it gave (until then it
        leaves the cores to planning)."""
        if self._pool is not None:
            self._pool.release_paths()

    def _collect(self) -> None:
        """Waits for the pool's batches and keeps (and caches) their full results,
        in the order the pairs were asked for, not the order they finished."""
        self.release_paths()
        done: dict[Pair, ReachResult] = {}
        for batch in self._batches:
            done.update(batch.result())
        self._batches.clear()
        for pair in list(self._decided):
            self._keep(pair, done[pair])
        self._decided.clear()

    def _reach_key(self, arm: str, target: str | Site) -> str:
        return f"{self.key}/reach/{arm}/{target}"

    def pairs(self) -> list[tuple[str, str]]:
        """Every (arm, part) pair, in file order: movable parts and the top alike."""
        arms, parts = self.scenario.robot.manipulators, self.scenario.parts
        return [(arm, p.id) for arm in arms for p in parts]

    def table(self) -> dict[tuple[str, str], ReachResult]:
        """Every (arm, part) pair, in file order, with its path."""
        self.answers()
        return {pair: self.reach(*pair) for pair in self.pairs()}

    def site_known(self, arm: str, site: Site) -> bool:
        """Whether `reach_site(arm, site)` is answered without a check (known, decided
        in the pool, or cached)."""
        if (arm, site) in self._site_reach or (arm, str(site)) in self._decided:
            return True
        pending = self._site_pending.get((arm, site))
        if pending is not None:
            return pending.done()
        stored = self.cache.get(self._reach_key(arm, site))
        if stored is not None:
            self._site_reach[(arm, site)] = ReachResult(**stored)
        return stored is not None

    def reaches_site(self, arm: str, site: Site) -> bool:
        """Whether `arm` reaches `site` (as `reach_site` says), without waiting for
        the path of an answer the pool decided."""
        return self._answer(arm, str(site))

    def reach_site(self, arm: str, site: Site) -> ReachResult:
        """Can `arm` reach `site` from home, top-down as it reaches a work point?"""
        if (arm, str(site)) in self._decided:
            self._collect()
        if (arm, site) in self._site_reach:
            return self._site_reach[(arm, site)]
        key = self._reach_key(arm, site)
        pending = self._site_pending.pop((arm, site), None)
        stored = self.cache.get(key) if pending is None else None
        if stored is not None:
            result = ReachResult(**stored)
        else:
            if pending is None and self.pool is not None:
                # The pool's processes have the robot loaded; this one may not.
                pending = self.pool.reach(arm, str(site))
            result = (
                pending.result()
                if pending is not None
                else self.world.check_reach(arm, site.part, site.point)
            )
            self.cache.put(key, result.__dict__)
        self._site_reach[(arm, site)] = result
        return result

    def prefetch_sites(self, sites: Iterable[tuple[str, Site]]) -> None:
        """Starts the reach checks of `sites` not answered yet, in the pool, side by
        side (`reach_site` then takes them from there)."""
        for arm, site in sites:
            if (arm, site) in self._site_pending or self.site_known(arm, site):
                continue
            if self.pool is None:
                return
            self._site_pending[(arm, site)] = self.pool.reach(arm, str(site))

    def at(self, arm: str, place: Place | None) -> Config:
        """Where `arm` stands when working at `place` (None: home): where its reach
        path ends, known from the decision before the path is made."""
        if place is None:
            return list(HOME[arm])
        goal = self._goals.get((arm, str(place)))
        return list(goal) if goal is not None else self._reach_path(arm, place)[-1]

    def move(self, arm: str, start: Place | None, goal: Place | None) -> list[Config]:
        """A collision-free path of `arm` from `start` to `goal` (None: home). Paths to
        and from home are the reach paths; between two places the motion planner is
        asked, and if it finds nothing the arm goes by home."""
        if start == goal:
            return [self.at(arm, start)]
        if start is None:
            assert goal is not None  # both None returned above
            return self._reach_path(arm, goal)
        if goal is None:
            return self._reach_path(arm, start)[::-1]
        key = f"{self.key}/move/{arm}/{start}/{goal}"
        pending = self._move_pending.pop((arm, start, goal), None)
        if pending is not None:
            direct = pending.result()
        else:
            stored = self.cache.get(key)
            if stored is not None:
                return list(stored)
            direct = self.world.move(
                arm, self.at(arm, start), self.at(arm, goal), _touched(start, goal)
            )
        path = direct or self._reach_path(arm, start)[::-1] + self._reach_path(arm, goal)[1:]
        self.cache.put(key, path)
        return path

    def prefetch_moves(self, moves: Iterable[Move]) -> None:
        """Starts the part-to-part motions of `moves` that are not cached, in the pool."""
        for arm, start, goal in moves:
            if start == goal or (arm, start, goal) in self._move_pending:
                continue
            # The cache first: a plan whose motions are all cached starts no process.
            if self.cache.get(f"{self.key}/move/{arm}/{start}/{goal}") is not None:
                continue
            if self.pool is None:
                return
            self._move_pending[(arm, start, goal)] = self.pool.move(
                arm, self.at(arm, start), self.at(arm, goal), _touched(start, goal)
            )

    def _reach_path(self, arm: str, place: Place) -> list[Config]:
        result = self.reach(arm, place) if isinstance(place, str) else self.reach_site(arm, place)
        if result.path is None:
            raise ValueError(f"{arm} cannot reach {place}")
        return result.path


def _touched(*places: Place) -> frozenset[str]:
    """The parts the gripper may touch on a move between `places`."""
    return frozenset(p if isinstance(p, str) else p.part for p in places)
