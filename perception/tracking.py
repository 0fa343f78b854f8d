"""One track per part across frames: smoothed position, confidence, and a timeout.

- Smoothing: the component-wise median of the last `window` accepted sightings
  (robust to a single bad decode, unlike a mean).
- Hysteresis: a sighting more than `jump_m` from the track is held back; only
  `confirm_frames` consecutive sightings that agree move the track there.
- Timeout: a part unseen for `timeout_s` becomes unknown. It keeps its last known
  position: a track is never moved without being seen.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from perception.observe import FrameObservation
from perception.pose import PartSighting

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class TrackerSettings:
    window: int = 5
    jump_m: float = 0.06
    confirm_frames: int = 3
    timeout_s: float = 0.5
    confidence_window: int = 15


@dataclass(frozen=True)
class Track:
    part_id: str
    marker_id: int
    position: Vec3  # smoothed centre of the code (the part's top face)
    yaw: float
    known: bool  # False once unseen for longer than the timeout
    last_seen_index: int
    last_seen_time: float
    frames_seen: int
    confidence: float  # share of the recent frames it was seen in, 0..1


class _PartHistory:
    def __init__(self, sighting: PartSighting, settings: TrackerSettings) -> None:
        self.marker_id = sighting.marker_id
        self.accepted: deque[PartSighting] = deque([sighting], maxlen=settings.window)
        self.pending: list[PartSighting] = []
        self.hits: deque[bool] = deque(maxlen=settings.confidence_window)
        self.frames_seen = 0
        self.last_index = -1
        self.last_time = -math.inf

    def position(self) -> Vec3:
        m = np.median(np.array([s.position for s in self.accepted]), axis=0)
        return (float(m[0]), float(m[1]), float(m[2]))

    def yaw(self) -> float:
        # Mean of angles on the circle; a median of raw angles breaks at +-pi.
        a = np.array([s.yaw for s in self.accepted])
        return float(np.arctan2(np.sin(a).mean(), np.cos(a).mean()))


class Tracker:
    def __init__(self, settings: TrackerSettings | None = None) -> None:
        self.settings = settings or TrackerSettings()
        self._parts: dict[str, _PartHistory] = {}
        self._now = 0.0

    def _see(self, history: _PartHistory, sighting: PartSighting) -> None:
        s = self.settings
        if math.dist(sighting.position, history.position()) <= s.jump_m:
            history.accepted.append(sighting)
            history.pending.clear()
            return
        pending = history.pending
        if pending and math.dist(sighting.position, pending[-1].position) > s.jump_m:
            history.pending.clear()  # the candidate move did not hold still: start over
        history.pending.append(sighting)
        if len(history.pending) >= s.confirm_frames:
            history.accepted.clear()
            history.accepted.extend(history.pending)
            history.pending.clear()

    def update(self, observation: FrameObservation) -> dict[str, Track]:
        self._now = observation.timestamp
        seen: set[str] = set()
        for sighting in observation.sightings:
            if sighting.part_id in seen:
                continue
            seen.add(sighting.part_id)
            history = self._parts.get(sighting.part_id)
            if history is None:
                history = self._parts[sighting.part_id] = _PartHistory(sighting, self.settings)
            else:
                self._see(history, sighting)
            history.frames_seen += 1
            history.last_index = observation.frame_index
            history.last_time = observation.timestamp
        for part_id, history in self._parts.items():
            history.hits.append(part_id in seen)
        return self.tracks()

    def forget(self, part_ids: Iterable[str]) -> None:
        for part_id in part_ids:
            self._parts.pop(part_id, None)

    def tracks(self) -> dict[str, Track]:
        out: dict[str, Track] = {}
        for part_id, h in self._parts.items():
            known = self._now - h.last_time <= self.settings.timeout_s
            out[part_id] = Track(
                part_id,
                h.marker_id,
                h.position(),
                h.yaw(),
                known,
                h.last_index,
                h.last_time,
                h.frames_seen,
                sum(h.hits) / len(h.hits) if h.hits else 0.0,
            )
        return out
