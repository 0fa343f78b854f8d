"""World queries answered by worker processes, each with its own pybullet client.

IK and OMPL hold the GIL, so threads give no speed-up: each process opens its
own `World` (a DIRECT client made after the fork) on first use. Every query
reseeds its random numbers from its own arguments (`World.check_reach`,
`World.move`), so an answer does not depend on which process gave it or what it
answered before.

Reach checks are asked for in batches (`decide`), each pair with the IK answers
the asking process found for it (`grasp_ik`): the processes take pairs from one
queue as they become free, report each answer the moment it is known, and
simplify the paths of the pairs they found reachable only after the queue is
empty and `release_paths` was called, so planning starts without waiting for
paths and the first branch need not share the cores with their smoothing.
"""

from __future__ import annotations

import multiprocessing as mp
import queue
import threading
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any

from planner.feasibility.grasp_ik import GraspIk, IkAnswers, Question
from planner.feasibility.reach import ReachDecision, ReachResult, Reason, World, robot_only
from planner.feasibility.robot import BaxterBody
from planner.feasibility.scene import Site, part_boxes
from planner.scenario_model import Scenario

Config = list[float]
Pair = tuple[str, str]  # arm, and a part id or a Site's text ("top@c2")

_world: World | None = None
_setup: tuple[Scenario, dict[str, Any]] | None = None
_pairs: Any = None  # the queue of pairs to decide; None marks the end of a batch
_decided: Any = None  # (pair, reachable, reason, goal) back to the parent, as decided
_go: Any = None  # set when the paths may be simplified
# Baxter loaded once per base pose in the process that makes pools, never used there:
# the processes forked from it find the robot loaded and add only their scene.
_robots: dict[tuple[float, ...], BaxterBody] = {}
_robots_lock = threading.Lock()
# The same robots answer IK here (`CheckPool.first_batches`), one planner at a time.
_ik_lock = threading.Lock()


def _init(scenario: Scenario, options: dict[str, Any], pairs: Any, decided: Any, go: Any) -> None:
    global _setup, _world, _pairs, _decided, _go
    _setup, _world = (scenario, options), None
    _pairs, _decided, _go = pairs, decided, go


def _own_world() -> World:
    global _world
    if _world is None:
        assert _setup is not None
        scenario, options = _setup
        robot = _robots.get(tuple(scenario.robot.base_pose))
        _world = World(scenario, robot=robot, **options)
    return _world


def _decide_then_finish() -> dict[Pair, ReachResult]:
    world = _own_world()
    mine: list[tuple[Pair, ReachDecision]] = []
    while (item := _pairs.get()) is not None:
        pair, given = item
        arm, target = pair
        decision = world.decide_reach(arm, *_part_and_point(target), ik=given)
        _decided.put((pair, decision.reachable, decision.reason, decision.goal))
        mine.append((pair, decision))
    _go.wait()
    assert _setup is not None
    # A fixed part is never held: no motion starts or ends at its work point (attaches
    # go to its points' sites), so its path is not made.
    fixed = {p.id for p in _setup[0].parts if not p.movable}
    return {
        pair: world.answer_only(decision) if pair[1] in fixed else world.finish_reach(decision)
        for pair, decision in mine
    }


def _reach(arm: str, target: str) -> ReachResult:
    return _own_world().check_reach(arm, *_part_and_point(target))


def question(pair: Pair) -> Question:
    """The reach question of an (arm, part id or Site's text) pair."""
    return Question(pair[0], *_part_and_point(pair[1]))


def _part_and_point(target: str) -> tuple[str, str | None]:
    """A part id, or a Site's text: what `World.check_reach` takes."""
    site = Site.parse(target)
    return (target, None) if site is None else (site.part, site.point)


def _move(arm: str, start: Config, goal: Config, parts: frozenset[str]) -> list[Config] | None:
    return _own_world().move(arm, start, goal, parts)


def _warm_up() -> bool:
    _own_world()
    return True


class CheckPool:
    """`workers` processes answering `World.check_reach` and `World.move` queries."""

    def __init__(self, scenario: Scenario, options: dict[str, Any], workers: int) -> None:
        with _robots_lock:
            pose = tuple(scenario.robot.base_pose)
            if pose not in _robots:
                _robots[pose] = robot_only(list(pose))
            self._robot = _robots[pose]
        self._setup = (scenario, options)
        context = mp.get_context("fork")
        self._workers = workers
        self._pairs: Any = context.Queue()
        self._decided: Any = context.Queue()
        self._go: Any = context.Event()
        self._pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=context,
            initializer=_init,
            initargs=(scenario, options, self._pairs, self._decided, self._go),
        )
        # Every process loads the robot at once, while the first answers are awaited.
        for _ in range(workers):
            self._pool.submit(_warm_up)

    def first_batches(
        self, questions: Iterable[Question]
    ) -> Iterator[tuple[Question, IkAnswers | None]]:
        """`GraspIk.first_batches` in this process, while the check processes start."""
        scenario, options = self._setup
        with _ik_lock:
            ik = GraspIk(self._robot, part_boxes(scenario), options.get("seed", 0))
            yield from ik.first_batches(questions)

    def decide(
        self, pairs: Iterable[tuple[Pair, IkAnswers | None]]
    ) -> list[Future[dict[Pair, ReachResult]]]:
        """Starts the reach checks of `pairs`, each with its first IK answers if known
        (`first_batches`); the futures give their full results (with paths),
        `decisions` the answers as they come. The processes take each pair as soon
        as `pairs` gives it (it may be a generator still solving IK)."""
        batches = [self._pool.submit(_decide_then_finish) for _ in range(self._workers)]
        for item in pairs:
            self._pairs.put(item)
        for _ in range(self._workers):
            self._pairs.put(None)  # one end mark per batch: each stops at one
        return batches

    def release_paths(self) -> None:
        """Lets the processes simplify the paths they decided (and all later ones)."""
        self._go.set()

    def decisions(
        self, count: int, batches: Sequence[Future[dict[Pair, ReachResult]]]
    ) -> Iterator[tuple[Pair, bool, Reason, Config | None]]:
        """The next `count` answers, in the order they were decided, each with where
        the arm will stand (`ReachDecision.goal`)."""
        for _ in range(count):
            while True:
                try:
                    pair, reachable, reason, goal = self._decided.get(timeout=0.5)
                    break
                except queue.Empty:
                    # A process that died never answers: its batch says why.
                    for batch in batches:
                        if batch.done() and batch.exception() is not None:
                            raise RuntimeError("a check process failed") from batch.exception()
            yield pair, reachable, reason, goal

    def reach(self, arm: str, target: str) -> Future[ReachResult]:
        """One reach check with its path, outside any batch (a part id or a Site's text)."""
        return self._pool.submit(_reach, arm, target)

    def move(
        self, arm: str, start: Config, goal: Config, parts: frozenset[str]
    ) -> Future[list[Config] | None]:
        return self._pool.submit(_move, arm, start, goal, parts)

    def close(self) -> None:
        self._go.set()  # a batch waiting for it would never end
        self._pool.shutdown(wait=True, cancel_futures=True)
