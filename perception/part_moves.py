"""When a part was moved: a code leaving the pose it rested at, until it rests again.

Each part's code is followed in its raw sightings, frame by frame (the tracker's
smoothing and jump hysteresis would delay a move by several frames):

- At rest, the code has a pose: the median of its first `rest_window` sightings
  there, then kept (a pose that followed every sighting would creep along with a
  hand that starts slowly).
- A sighting more than `move_m` from that pose, or turned more than `move_yaw`,
  is off it; `confirm_frames` such sightings in a row start a move (one bad
  decode does not). The move starts at the last frame that still showed the code
  at its pose (within `still_m` and `still_yaw`): the true start lies between
  that frame and the next, while the first frame off comes late by the time the
  part needs to cover `move_m` as well, so the last frame at rest errs less.
- Moving, the code settles once its sightings stay within `still_m` (and
  `still_yaw`) of the latest one for `settle_s` and at least `settle_frames`
  frames; the move ends at the first frame of that still stretch (its first
  frame at the new pose). Past `hand_x`, in the human's hands, a part is never
  quite still: there `hand_still_m` counts as still, and only `hand_move_m`
  takes it out of the hands.
- A moving code unseen for `vanish_s` went out of sight (into a hand, out of the
  frame): the move ends at the last frame that saw it. A code at rest that goes
  unseen was hidden (a hand over it) unless it comes back elsewhere: then it moved
  from its last sighting at rest until it settles.

The start errs early and the end late by at most a frame's interval each: the
interval found holds the true one. Times are whatever the caller stamps each
observation with (a live camera: each frame's capture time on the wall clock).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from perception.observe import FrameObservation
from perception.pose import PartSighting

Vec3 = tuple[float, float, float]
MoveEnd = Literal["settled", "vanished"]


@dataclass(frozen=True)
class MoveSettings:
    # A still code's sightings in 640 px frames rendered with blur, noise, gain and
    # light changes lie within 1-2 mm of their median (95 %; yaw within 0.1 deg); a
    # part a person moves goes centimetres: 1.5 cm is well above the scatter, with
    # room for a real webcam's, and well below the smallest part (4 cm).
    move_m: float = 0.015
    # A part turned by hand turns by tens of degrees.
    move_yaw: float = math.radians(15.0)
    # Two sightings off the pose in a row: now and then one frame's camera pose is
    # off and puts every code metres away; that is no move.
    confirm_frames: int = 2
    # Still: within 1 cm of the latest sighting (a slow hand moves more than that in
    # a few frames) for 0.3 s and 3 frames (a hand pausing mid-move is shorter).
    still_m: float = 0.01
    still_yaw: float = math.radians(8.0)
    settle_s: float = 0.3
    settle_frames: int = 3
    # In the human's hands a part sways by a few centimetres while held still; it
    # leaves them (attached, put down) by more than 5 cm.
    hand_still_m: float = 0.03
    hand_move_m: float = 0.05
    # The tracker's timeout: unseen this long, a moving code went out of sight.
    vanish_s: float = 0.5
    rest_window: int = 5  # sightings whose median is the pose at rest


@dataclass(frozen=True)
class Pose:
    position: Vec3  # the code's centre, in the bench frame
    yaw: float


@dataclass(frozen=True)
class PartMove:
    """One part moved from `start` to `end`: from the pose it rested at to the pose it
    settled at (None when it went out of sight, `ended` "vanished")."""

    part_id: str
    from_pose: Pose
    to_pose: Pose | None
    start: float
    end: float
    ended: MoveEnd
    in_hand: bool  # it settled past `hand_x`, in the human's hands


@dataclass(frozen=True)
class _Seen:
    at: float
    pose: Pose


def _yaw_apart(a: float, b: float) -> float:
    return abs(math.atan2(math.sin(a - b), math.cos(a - b)))


def _median_pose(seen: Iterable[_Seen]) -> Pose:
    items = list(seen)
    m = np.median(np.array([s.pose.position for s in items]), axis=0)
    yaws = np.array([s.pose.yaw for s in items])
    yaw = float(np.arctan2(np.sin(yaws).mean(), np.cos(yaws).mean()))
    return Pose((float(m[0]), float(m[1]), float(m[2])), yaw)


@dataclass
class _Part:
    """One code's state: at rest (`rest` set, `moving` empty) or moving."""

    rest: deque[_Seen]
    last_rest: float  # the last frame that showed it still at its pose
    last_seen: float
    off: list[_Seen] = field(default_factory=list)  # sightings off the pose, not yet a move
    moving: list[_Seen] = field(default_factory=list)
    from_pose: Pose | None = None  # set while moving
    start: float = 0.0


class MoveWatch:
    """Follows every part's code over observations and says which moves ended."""

    def __init__(self, settings: MoveSettings | None = None, hand_x: float | None = None) -> None:
        self.settings = settings or MoveSettings()
        self.hand_x = hand_x
        self._parts: dict[str, _Part] = {}

    def moving(self) -> dict[str, float]:
        """The parts moving now, with when each move started."""
        return {pid: p.start for pid, p in self._parts.items() if p.from_pose is not None}

    def update(self, observation: FrameObservation, at: float | None = None) -> list[PartMove]:
        """The moves that ended with this observation, taken at `at` (by default the
        observation's own time stamp)."""
        now = observation.timestamp if at is None else at
        ended: list[PartMove] = []
        seen: set[str] = set()
        for sighting in observation.sightings:
            if sighting.part_id in seen:
                continue  # one sighting a part a frame, as the tracker takes it
            seen.add(sighting.part_id)
            move = self._see(sighting, now)
            if move is not None:
                ended.append(move)
        for pid, part in list(self._parts.items()):
            if pid not in seen:
                move = self._unseen(pid, part, now)
                if move is not None:
                    ended.append(move)
        return ended

    def _see(self, sighting: PartSighting, now: float) -> PartMove | None:
        s = _Seen(now, Pose(sighting.position, sighting.yaw))
        part = self._parts.get(sighting.part_id)
        if part is None:
            self._parts[sighting.part_id] = self._resting(s)
            return None
        part.last_seen = now
        if part.from_pose is None:
            self._at_rest(part, s)
            return None
        part.moving.append(s)
        return self._settled(sighting.part_id, part)

    def _resting(self, s: _Seen) -> _Part:
        return _Part(deque([s], maxlen=self.settings.rest_window), s.at, s.at)

    def _in_hand(self, pose: Pose) -> bool:
        return self.hand_x is not None and pose.position[0] > self.hand_x

    def _at_rest(self, part: _Part, s: _Seen) -> None:
        cfg = self.settings
        pose = _median_pose(part.rest)
        held = self._in_hand(pose)
        apart = math.dist(s.pose.position, pose.position)
        turned = _yaw_apart(s.pose.yaw, pose.yaw)
        off = apart > (cfg.hand_move_m if held else cfg.move_m) or turned > cfg.move_yaw
        if not off:
            if len(part.rest) < cfg.rest_window:
                part.rest.append(s)
            if apart <= (cfg.hand_still_m if held else cfg.still_m) and turned <= cfg.still_yaw:
                part.last_rest = s.at
            part.off.clear()
            return
        part.off.append(s)
        if len(part.off) >= cfg.confirm_frames:
            part.from_pose, part.start = pose, part.last_rest
            part.moving, part.off = list(part.off), []

    def _settled(self, part_id: str, part: _Part) -> PartMove | None:
        """The move's end, once its latest sightings have kept still long enough."""
        cfg = self.settings
        latest = part.moving[-1]
        in_hand = self._in_hand(latest.pose)
        still_m = cfg.hand_still_m if in_hand else cfg.still_m
        first = len(part.moving) - 1
        while first > 0:
            other = part.moving[first - 1].pose
            if (
                math.dist(other.position, latest.pose.position) > still_m
                or _yaw_apart(other.yaw, latest.pose.yaw) > cfg.still_yaw
            ):
                break
            first -= 1
        still = part.moving[first:]
        if len(still) < cfg.settle_frames or latest.at - still[0].at < cfg.settle_s:
            return None
        assert part.from_pose is not None
        move = PartMove(
            part_id, part.from_pose, _median_pose(still), part.start, still[0].at,
            "settled", in_hand,
        )  # fmt: skip
        rest = self._resting(still[0])
        rest.rest.extend(still[1:])
        rest.last_rest = rest.last_seen = latest.at
        self._parts[part_id] = rest
        return move

    def _unseen(self, part_id: str, part: _Part, now: float) -> PartMove | None:
        if now - part.last_seen < self.settings.vanish_s:
            return None
        part.off.clear()
        if part.from_pose is None:
            return None  # hidden at rest: a move only if it comes back elsewhere
        move = PartMove(part_id, part.from_pose, None, part.start, part.last_seen, "vanished",
                        False)  # fmt: skip
        # Out of sight: wherever it is seen next, it rests there.
        del self._parts[part_id]
        return move


def part_moves(
    observations: Iterable[tuple[float, FrameObservation]],
    settings: MoveSettings | None = None,
    hand_x: float | None = None,
) -> list[PartMove]:
    """Every move that ended over `observations`, each taken at the time beside it."""
    watch = MoveWatch(settings, hand_x)
    moves: list[PartMove] = []
    for at, observation in observations:
        moves.extend(watch.update(observation, at))
    return moves
