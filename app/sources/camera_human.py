"""The human's actions a live camera sees, kept as `human` events of the execution.

A `HumanActionWatch` follows every view of a camera that keeps watching
(app/sources/live_camera.py), finds each part's moves with
`perception.part_moves.MoveWatch` (a code leaving the pose it rested at starts a
move, its settling at a new pose, in the hands included, or going out of sight
ends it), and keeps each move as a `human` event, source "camera", from its start
to its end on the wall clock (the frames' capture times). What the plan expected
does not matter: a take, a putdown, an attach, a handback or a detach the plan did
not count on is the human's activity too.

The robot moves parts as well. A move of a part in the robot's gripper (from the
start of the robot's `hold` of it to `RELEASE_S` after its `unhold`), or of a part
attached to one, is the robot's and is not kept; the watch learns what the robot
holds from the execution's events (`on_event`, a listener).
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass

from app.execution.events import ExecutionControls, ExecutionEvent
from app.execution.evidence import Evidence
from app.sources.camera import jpeg
from app.sources.camera_reading import where_words
from app.sources.live_camera import LiveCamera, LiveView
from perception.part_moves import MoveSettings, MoveWatch, PartMove
from perception.world import Placement, Where
from planner.vocabulary import Hold, Unhold

# After the robot's unhold is recorded the part may still settle (a simulated world
# puts it down when the event arrives): moves starting this soon after are the robot's.
RELEASE_S = 0.5
# Placements kept to say where a part was when its move started: 10 s at 30 fps.
HISTORY_VIEWS = 300


@dataclass
class _Custody:
    """The robot held `part` from `since` until `until` (None: it still does)."""

    part: str
    since: float
    until: float | None = None


class HumanActionWatch:
    """Keeps the human's moves of parts that `live`'s views show as `human` events of
    the execution it is attached to, from then until it is detached; `on_event` takes
    the execution's events (a listener). Past the bench's human-side edge a part is in
    the human's hands."""

    def __init__(self, live: LiveCamera, settings: MoveSettings | None = None) -> None:
        self.live = live
        self.moves = MoveWatch(settings, live.layout.human_side_x)
        self.kept: list[PartMove] = []  # the moves kept as the human's, for a caller
        self.robots: list[PartMove] = []  # the moves left to the robot
        self._controls: ExecutionControls | None = None
        self._lock = threading.Lock()
        self._custody: list[_Custody] = []
        self._arms: dict[str, _Custody] = {}
        self._placed: deque[tuple[float, dict[str, Placement]]] = deque(maxlen=HISTORY_VIEWS)

    # -- the execution (attach/detach by the walker, through the camera source) --------

    def attach(self, controls: ExecutionControls) -> None:
        with self._lock:
            self._controls = controls
        self.live.watchers.append(self.see)

    def detach(self, controls: ExecutionControls) -> None:
        with self._lock:
            self._controls = None
        if self.see in self.live.watchers:
            self.live.watchers.remove(self.see)

    def on_event(self, event: ExecutionEvent) -> None:
        """What the robot holds, from its `hold` and `unhold` actions."""
        start = event.start if event.start is not None else event.time
        end = event.end if event.end is not None else event.time
        with self._lock:
            match event.action:
                case Hold(arm, part):
                    self._arms[arm] = _Custody(part, start)
                    self._custody.append(self._arms[arm])
                case Unhold(arm) if arm in self._arms:
                    self._arms.pop(arm).until = end

    # -- the camera's views (its own thread) ---------------------------------------------

    def see(self, view: LiveView) -> None:
        world = view.perceived.world
        placed = {pid: p.placement for pid, p in world.parts.items()}
        moves = self.moves.update(view.perceived.observation, view.captured)
        with self._lock:
            self._placed.append((view.captured, placed))
            controls = self._controls
            human = [m for m in moves if not self._robots(m)]
            self.robots.extend(m for m in moves if m not in human)
        if controls is None:
            return  # no execution runs: nobody to tell
        for move in human:
            self.kept.append(move)
            words = self._words(move, placed.get(move.part_id))
            # The frame that showed the end of the move, for the review.
            evidence = Evidence(jpeg=jpeg(view.frame))
            controls.observe_human(move.start, move.end, words, "camera", evidence)

    def _before(self, at: float) -> dict[str, Placement]:
        """Where the parts were at `at`: the latest placements taken by then."""
        found: dict[str, Placement] = {}
        for taken, placed in self._placed:
            if taken > at:
                break
            found = placed
        return found

    def _robots(self, move: PartMove) -> bool:
        """Whether the robot moved it: it, or a part it was attached to, in the gripper."""
        before = self._before(move.start)
        carried = {move.part_id}
        part: str | None = move.part_id
        while part is not None:
            placement = before.get(part)
            part = placement.attached_to if placement is not None else None
            if part in carried:
                break
            if part is not None:
                carried.add(part)
        return any(
            c.part in carried
            and c.since <= move.end
            and (c.until is None or move.start <= c.until + RELEASE_S)
            for c in self._custody
        )

    def _words(self, move: PartMove, after: Placement | None) -> str:
        """The move in words: the part, where it was, where it went."""
        before = self._before(move.start).get(move.part_id)
        was = "" if before is None else f", {where_words(before)} before"
        if move.ended == "vanished":
            return f"the human moved {move.part_id}{was}, out of sight now"
        if after is not None and after.where is not Where.UNKNOWN:
            now = where_words(after)
        else:
            now = "in the human's hands" if move.in_hand else "at a new pose"
        return f"the human moved {move.part_id}{was}, {now} now"
