"""A simulated person's hands that take their time: each part the human handles goes
from where it was to where it ends along a straight line, over a drawn duration,
on the wall clock, in the hands' own thread (the robot goes on meanwhile).

A live simulated camera films the part on its way, as a camera would film a
person, and `moves` keeps each move's true start and end: the wall-clock time
the part first left its pose in the camera's scene, and the time it arrived.
"""

from __future__ import annotations

import math
import queue
import random
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal, Protocol

Vec3 = tuple[float, float, float]
PartPose = tuple[Vec3, float]  # a box's centre and yaw
HandAction = Literal["take", "putdown", "attach"]
# A person reaching for a part and bringing it to the hands, or putting one down:
# about a second (0.8-1.6 s), drawn per move.
HAND_SECONDS = (0.8, 1.6)
STEP_HZ = 60.0  # poses a second along the way: finer than any camera's frames
# Between two moves the hands hold still a moment, as a person's do between taking a
# part and attaching it: longer than a camera needs to see the part settle
# (perception.part_moves.MoveSettings.settle_s), else it sees one move, not two.
HAND_REST_S = 0.6


class ScenePart(Protocol):
    """What the hands move: the simulated camera's scene."""

    def move(self, part_id: str, position: Vec3, yaw: float | None = None) -> None: ...


@dataclass(frozen=True)
class TrueMove:
    """One part the simulated human moved, and when (epoch seconds)."""

    part: str
    action: HandAction
    start: float
    end: float


@dataclass(frozen=True)
class _Job:
    action: HandAction
    part: str
    paths: Mapping[str, tuple[PartPose, PartPose]]  # each part that moves: from, to
    arrived: Callable[[Mapping[str, PartPose]], None]


def _between(a: PartPose, b: PartPose, f: float) -> PartPose:
    (pa, ya), (pb, yb) = a, b
    turn = math.atan2(math.sin(yb - ya), math.cos(yb - ya))  # the shorter way round
    position = (pa[0] + (pb[0] - pa[0]) * f, pa[1] + (pb[1] - pa[1]) * f,
                pa[2] + (pb[2] - pa[2]) * f)  # fmt: skip
    return position, ya + turn * f


class PacedHands:
    """Moves parts in `scene` one job after another, each over a duration drawn
    (seeded) from `seconds`; `wait()` returns once all submitted moves are done."""

    def __init__(
        self,
        scene: ScenePart,
        seed: int | None = None,
        seconds: tuple[float, float] = HAND_SECONDS,
    ) -> None:
        self.scene = scene
        self.seconds = seconds
        self.moves: list[TrueMove] = []
        self._rng = random.Random(seed)
        self._jobs: queue.Queue[_Job | None] = queue.Queue()
        self._idle = threading.Condition()
        self._pending = 0
        self._rested_from = 0.0  # when the last move ended (time.monotonic())
        # The hands' thread runs while there are moves to make: one made per execution
        # (the dashboard's) must not outlive it.
        self._thread: threading.Thread | None = None

    def submit(
        self,
        action: HandAction,
        part: str,
        paths: Mapping[str, tuple[PartPose, PartPose]],
        arrived: Callable[[Mapping[str, PartPose]], None],
    ) -> None:
        """Moves each part of `paths` (`part` and what comes with it) from its first
        pose to its second; `arrived` is told the poses they are shown at once there."""
        with self._idle:
            self._pending += 1
            self._jobs.put(_Job(action, part, dict(paths), arrived))
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._run, name="simulated-hands", daemon=True
                )
                self._thread.start()

    def wait(self, timeout: float = 30.0) -> None:
        """Until every move submitted so far is done."""
        with self._idle:
            self._idle.wait_for(lambda: self._pending == 0, timeout)

    def close(self) -> None:
        with self._idle:
            if self._thread is not None:
                self._jobs.put(None)

    def _run(self) -> None:
        while True:
            with self._idle:
                try:
                    job = self._jobs.get_nowait()
                except queue.Empty:
                    self._thread = None  # done: the next move starts another
                    return
            if job is None:
                with self._idle:
                    self._thread = None
                return
            try:
                self._move(job)
            finally:
                with self._idle:
                    self._pending -= 1
                    self._idle.notify_all()

    def _move(self, job: _Job) -> None:
        time.sleep(max(0.0, self._rested_from + HAND_REST_S - time.monotonic()))
        seconds = self._rng.uniform(*self.seconds)
        start = end = 0.0
        begun = time.monotonic()
        f = 0.0
        while f < 1.0:
            # Where the hands are by now: a scene that takes a while to move (a
            # camera drawing it meanwhile) gets fewer poses, not a slower person.
            time.sleep(1.0 / STEP_HZ)
            f = min(1.0, (time.monotonic() - begun) / seconds)
            for pid, (a, b) in job.paths.items():
                position, yaw = _between(a, b, f)
                self.scene.move(pid, position, yaw)
            end = time.time()  # the scene shows this pose from now on
            start = start or end
        self._rested_from = time.monotonic()
        job.arrived({pid: b for pid, (_, b) in job.paths.items()})
        self.moves.extend(TrueMove(pid, job.action, start, end) for pid in job.paths)
