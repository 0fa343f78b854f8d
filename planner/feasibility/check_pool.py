"""World queries answered by worker processes, each with its own pybullet client.

IK and OMPL hold the GIL, so threads give no speed-up: each process opens its
own `World` (a DIRECT client made after the fork) on first use. Every query
reseeds its random numbers from its own arguments (`World.check_reach`,
`World.move`), so an answer does not depend on which process gave it or what it
answered before.

The IK of a bench's reach questions comes first (`first_batches`), one arm's in
each process, while the planning process waits for nothing but its answers. Reach
checks are then asked for in batches (`decide`), each pair with its IK answers
(`grasp_ik`): the processes take pairs from one queue as they become free and
report each answer the moment it is known. The path of a reachable pair is
simplified later, by the process that decided it (its search lives there), one
path per job and only after `release_paths`, so planning starts without waiting
for paths and the first branch need not share the cores with their smoothing.
Each process has a queue of its own: a motion or site check asked for meanwhile
goes to the least busy process and runs before its next path, since plan motions
wait for it and most paths are needed last.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from functools import partial
from typing import Any, TypeVar

from planner.feasibility.grasp_ik import GraspIk, IkAnswers, Question
from planner.feasibility.reach import ReachDecision, ReachResult, Reason, World, robot_only
from planner.feasibility.robot import BaxterBody
from planner.feasibility.scene import Site, part_boxes
from planner.scenario.model import Scenario

Config = list[float]
Pair = tuple[str, str]  # arm, and a part id or a Site's text ("top@c2")

_world: World | None = None
_setup: tuple[Scenario, dict[str, Any]] | None = None
_pairs: Any = None  # the queue of pairs to decide; None marks the end of a batch
_decided: Any = None  # (pair, reachable, reason, goal) back to the parent, as decided
# Decided here, their paths not made yet (`_finish` makes them).
_held: dict[Pair, ReachDecision] = {}
# Baxter loaded once per base pose in the process that makes pools, never used there:
# the processes forked from it find the robot loaded and add only their scene.
_robots: dict[tuple[float, ...], BaxterBody] = {}
_robots_lock = threading.Lock()
# The check processes' niceness (their scheduling priority, lowered): a plan waits
# for the planning process far more than for them, so its grounding and solving
# come first and the checks take the cores it leaves; on 2 cores the three
# processes used to share them evenly. (Raising it back would need privileges:
# the processes are new for each bench.)
NICENESS = 10


def _init(scenario: Scenario, options: dict[str, Any], pairs: Any, decided: Any) -> None:
    global _setup, _world, _pairs, _decided
    os.nice(NICENESS)
    _setup, _world = (scenario, options), None
    _pairs, _decided = pairs, decided
    _held.clear()


def _own_world() -> World:
    global _world
    if _world is None:
        assert _setup is not None
        scenario, options = _setup
        robot = _robots.get(tuple(scenario.robot.base_pose))
        _world = World(scenario, robot=robot, **options)
    return _world


def _decide() -> list[Pair]:
    """Decides pairs from the shared queue until its end mark; returns them in order."""
    world = _own_world()
    mine: list[Pair] = []
    while (item := _pairs.get()) is not None:
        pair, given = item
        arm, target = pair
        decision = world.decide_reach(arm, *_part_and_point(target), ik=given)
        _decided.put((pair, decision.reachable, decision.reason, decision.goal))
        _held[pair] = decision
        mine.append(pair)
    return mine


def _finish(pair: Pair) -> ReachResult:
    """The full answer of a pair this process decided, with its path."""
    world = _own_world()
    decision = _held.pop(pair)
    assert _setup is not None
    # A fixed part is never held: no motion starts or ends at its work point (attaches
    # go to its points' sites), so its path is not made.
    if pair[1] in {p.id for p in _setup[0].parts if not p.movable}:
        return world.answer_only(decision)
    return world.finish_reach(decision)


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


def _first_batches(questions: list[Question]) -> list[tuple[Question, IkAnswers | None]]:
    """`GraspIk.first_batches` of `questions` here: it needs the robot and the parts'
    boxes, not the world."""
    assert _setup is not None
    scenario, options = _setup
    robot = _robots[tuple(scenario.robot.base_pose)]
    ik = GraspIk(robot, part_boxes(scenario), options.get("seed", 0))
    return list(ik.first_batches(questions))


T = TypeVar("T")


@dataclass
class _Batch:
    """The pairs one process decided in one `decide`, and their full answers."""

    decided: Future[list[Pair]]  # the process's `_decide` job
    answers: Future[dict[Pair, ReachResult]] = field(default_factory=Future)
    made: dict[Pair, ReachResult] = field(default_factory=dict)
    left: list[Pair] | None = None  # the pairs whose paths are still to make


class CheckPool:
    """`workers` processes answering `World.check_reach` and `World.move` queries."""

    def __init__(self, scenario: Scenario, options: dict[str, Any], workers: int) -> None:
        with _robots_lock:
            pose = tuple(scenario.robot.base_pose)
            if pose not in _robots:
                _robots[pose] = robot_only(list(pose))
        self._setup = (scenario, options)
        context = mp.get_context("fork")
        self._pairs: Any = context.Queue()
        self._decided: Any = context.Queue()
        # One executor of one process each: a path must be made where its pair was
        # decided, and every process keeps its own order of work.
        self._processes = [
            ProcessPoolExecutor(
                max_workers=1,
                mp_context=context,
                initializer=_init,
                initargs=(scenario, options, self._pairs, self._decided),
            )
            for _ in range(workers)
        ]
        # Per process: its batches, and how many jobs it has queued or running.
        self._batches: list[list[_Batch]] = [[] for _ in range(workers)]
        self._queued = [0] * workers
        # A path job whose answer is not kept yet: its process's next path waits for
        # it, so that a batch is complete only once its last answer is in.
        self._finishing: list[bool] = [False] * workers
        self._released = False
        self._closed = False
        # Taken by the threads that submit and by executors' threads reporting a job done.
        self._lock = threading.RLock()

    def first_batches(
        self, questions: Iterable[Question]
    ) -> Iterator[tuple[Question, IkAnswers | None]]:
        """`GraspIk.first_batches` in the check processes, each arm's questions in one
        (a pass serves one arm), asked at once: before `decide`, whose jobs would
        hold the processes. Each arm's answers come together, the first arm done first."""
        by_arm: dict[str, list[Question]] = {}
        for q in questions:
            by_arm.setdefault(q.arm, []).append(q)
        solving = [
            self._submit(index % len(self._processes), _first_batches, asked)
            for index, asked in enumerate(by_arm.values())
        ]
        return (answer for done in as_completed(solving) for answer in done.result())

    def decide(
        self, pairs: Iterable[tuple[Pair, IkAnswers | None]]
    ) -> list[Future[dict[Pair, ReachResult]]]:
        """Starts the reach checks of `pairs`, each with its first IK answers if known
        (`first_batches`); the futures give their full results (with paths),
        `decisions` the answers as they come. The processes take each pair as soon
        as `pairs` gives it (it may be a generator still solving IK)."""
        batches = []
        with self._lock:
            for index in range(len(self._processes)):
                batch = _Batch(self._submit(index, _decide))
                self._batches[index].append(batch)
                batch.decided.add_done_callback(partial(self._decide_done, index))
                batches.append(batch.answers)
        try:
            for item in pairs:
                self._pairs.put(item)
        finally:
            # One end mark per batch: each stops at one, even when `pairs` failed
            # (its IK raised), so that no process waits for pairs forever.
            for _ in self._processes:
                self._pairs.put(None)
        return batches

    def release_paths(self) -> None:
        """Lets the processes make the paths they decided (and all later ones)."""
        with self._lock:
            self._released = True
            for index in range(len(self._processes)):
                self._schedule(index)

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
        return self._submit(self._least_busy(), _reach, arm, target)

    def move(
        self, arm: str, start: Config, goal: Config, parts: frozenset[str]
    ) -> Future[list[Config] | None]:
        return self._submit(self._least_busy(), _move, arm, start, goal, parts)

    def close(self) -> None:
        with self._lock:
            self._closed = True
        for process in self._processes:
            process.shutdown(wait=False, cancel_futures=True)
        for process in self._processes:
            process.shutdown(wait=True)
        with self._lock:
            for batches in self._batches:
                for batch in batches:
                    if not batch.answers.done():
                        batch.answers.set_exception(RuntimeError("the check pool closed"))

    # -- the order of work in each process
    def _least_busy(self) -> int:
        with self._lock:
            return min(range(len(self._processes)), key=lambda i: self._queued[i])

    def _submit(self, index: int, job: Callable[..., T], *args: Any) -> Future[T]:
        with self._lock:
            future = self._processes[index].submit(job, *args)
            self._queued[index] += 1
        future.add_done_callback(partial(self._done, index))
        return future

    def _done(self, index: int, _: Future[Any]) -> None:
        with self._lock:
            self._queued[index] -= 1
            self._schedule(index)

    def _decide_done(self, index: int, _: Future[list[Pair]]) -> None:
        self._schedule(index)

    def _schedule(self, index: int) -> None:
        """Queues the next path of process `index` once it has nothing else to do:
        motions and site checks asked meanwhile go first."""
        with self._lock:
            for batch in self._batches[index]:
                failed = batch.decided.done() and batch.decided.exception() is not None
                if failed and not batch.answers.done():
                    # A process that died deciding: `decisions` must not wait for it.
                    batch.answers.set_exception(batch.decided.exception())
            if self._closed or not self._released or self._finishing[index]:
                return
            if self._queued[index] > 0:
                return
            for batch in self._batches[index]:
                if batch.answers.done() or not batch.decided.done():
                    continue
                if batch.left is None:
                    batch.left = list(batch.decided.result())
                if not batch.left:
                    batch.answers.set_result(batch.made)
                    continue
                pair = batch.left.pop(0)
                self._finishing[index] = True
                made = self._submit(index, _finish, pair)
                made.add_done_callback(partial(self._made, index, batch, pair))
                return

    def _made(self, index: int, batch: _Batch, pair: Pair, made: Future[ReachResult]) -> None:
        with self._lock:
            self._finishing[index] = False
            if made.exception() is not None:
                if not batch.answers.done():
                    batch.answers.set_exception(made.exception())
            else:
                batch.made[pair] = made.result()
            self._schedule(index)
