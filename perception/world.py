"""What the tracks mean: where each part is, and what the human holds.

Each known track is classified in order:
1. attached to Q at slot C: over one of Q's slots (within `slot_tol_m`) with its
   bottom on Q's top face (within `stack_tol_m`);
2. held by the human: off the bench past its human-side edge;
3. on the bench in region R: its bottom on the bench top (within `rest_tol_m`);
4. lifted: by the robot over the robot's side (x < `lift_split_x`), else by the human.
A track that timed out is unknown (at its last known position). A new state must
hold `hysteresis_frames` frames before the estimate changes; unknown is reported at
once, since the track's timeout already waited.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

from perception.layout import BenchLayout
from perception.outline import OutlineEstimate
from perception.tracking import Track, Vec3


class Where(StrEnum):
    ON_BENCH = "on_bench"
    HELD_BY_HUMAN = "held_by_human"
    HELD_BY_ROBOT = "held_by_robot"
    ATTACHED = "attached"
    UNKNOWN = "unknown"


@dataclass(frozen=True)
class Placement:
    where: Where
    region: str | None = None  # for ON_BENCH
    attached_to: str | None = None  # for ATTACHED
    slot: str | None = None  # for ATTACHED


@dataclass(frozen=True)
class PartEstimate:
    part_id: str
    placement: Placement
    position: Vec3 | None  # last known centre of its box; None if never seen
    confidence: float  # 0..1
    age: int  # frames this placement has been reported
    outline: OutlineEstimate | None = None  # its top face's, for a part whose is open

    @property
    def where(self) -> Where:
        return self.placement.where


@dataclass(frozen=True)
class HumanEstimate:
    holding: tuple[str, ...]  # parts in the human's hands, most confident first
    confidence: float

    @property
    def hands_free(self) -> bool:
        return not self.holding


@dataclass(frozen=True)
class WorldEstimate:
    frame_index: int
    timestamp: float
    parts: dict[str, PartEstimate]
    human: HumanEstimate
    age: int  # frames the whole estimate has been unchanged
    stable: bool  # unchanged for at least `stable_frames`


@dataclass(frozen=True)
class WorldSettings:
    slot_tol_m: float = 0.05
    stack_tol_m: float = 0.05
    rest_tol_m: float = 0.05
    hysteresis_frames: int = 3
    stable_frames: int = 5


UNKNOWN = Placement(Where.UNKNOWN)


def part_centre(track: Track, layout: BenchLayout) -> Vec3:
    """The centre of a part's box from its code's track (the code is on its top face)."""
    x, y, z = track.position
    shape = layout.parts.get(track.part_id)
    if shape is None:
        return (x, y, z)
    dx, dy = shape.code_offset
    c, s = math.cos(track.yaw), math.sin(track.yaw)
    return (x - (c * dx - s * dy), y - (s * dx + c * dy), z - shape.size[2] / 2)


def classify(track: Track, tracks: Mapping[str, Track], layout: BenchLayout,
             settings: WorldSettings) -> Placement:
    """One frame's placement of a known track (no hysteresis)."""
    x, y, z = track.position  # the top face, at the code
    shape = layout.parts.get(track.part_id)
    bottom = z - (shape.size[2] if shape else 0.0)
    if shape is not None:
        x, y, _ = part_centre(track, layout)
    best: tuple[float, Placement] | None = None
    for other in tracks.values():
        other_shape = layout.parts.get(other.part_id)
        if other.part_id == track.part_id or not other.known or other_shape is None:
            continue
        ox, oy, _ = part_centre(other, layout)
        oz = other.position[2]
        if abs(bottom - oz) > settings.stack_tol_m:
            continue
        for slot, (dx, dy) in other_shape.slots.items():
            d = math.hypot(x - (ox + dx), y - (oy + dy))
            if d <= settings.slot_tol_m and (best is None or d < best[0]):
                best = (d, Placement(Where.ATTACHED, attached_to=other.part_id, slot=slot))
    if best is not None:
        return best[1]
    if x > layout.human_side_x:
        return Placement(Where.HELD_BY_HUMAN)
    if layout.on_bench(x, y) and bottom - layout.bench_top_z <= settings.rest_tol_m:
        return Placement(Where.ON_BENCH, region=layout.region_at(x))
    if x < layout.lift_split_x:
        return Placement(Where.HELD_BY_ROBOT)
    return Placement(Where.HELD_BY_HUMAN)


@dataclass
class _PartState:
    placement: Placement
    age: int = 1
    candidate: Placement | None = None
    candidate_frames: int = 0


class WorldEstimator:
    def __init__(self, layout: BenchLayout, settings: WorldSettings | None = None) -> None:
        self.layout = layout
        self.settings = settings or WorldSettings()
        self._states: dict[str, _PartState] = {}
        self._last_key: tuple[tuple[str, Placement], ...] | None = None
        self._age = 0

    def _settle(self, part_id: str, raw: Placement) -> tuple[_PartState, bool]:
        """Apply hysteresis; returns the state and whether `raw` agrees with it."""
        state = self._states.get(part_id)
        immediate = raw.where is Where.UNKNOWN or (
            state is not None and state.placement.where is Where.UNKNOWN
        )
        if state is None or immediate:
            if state is not None and state.placement == raw:
                state.age += 1
            else:
                state = self._states[part_id] = _PartState(raw)
            state.candidate, state.candidate_frames = None, 0
            return state, True
        if raw == state.placement:
            state.age += 1
            state.candidate, state.candidate_frames = None, 0
            return state, True
        if raw == state.candidate:
            state.candidate_frames += 1
        else:
            state.candidate, state.candidate_frames = raw, 1
        if state.candidate_frames >= self.settings.hysteresis_frames:
            state.placement, state.age = raw, state.candidate_frames
            state.candidate, state.candidate_frames = None, 0
            return state, True
        state.age += 1
        return state, False

    def update(
        self, tracks: Mapping[str, Track], frame_index: int, timestamp: float
    ) -> WorldEstimate:
        known = {pid: t for pid, t in tracks.items() if t.known}
        parts: dict[str, PartEstimate] = {}
        for part_id in sorted(set(self.layout.parts) | set(tracks)):
            track = tracks.get(part_id)
            if track is None:
                parts[part_id] = PartEstimate(part_id, UNKNOWN, None, 0.0, 0)
                continue
            raw = (
                classify(track, known, self.layout, self.settings) if track.known else UNKNOWN
            )
            state, agrees = self._settle(part_id, raw)
            confidence = track.confidence if agrees else track.confidence / 2
            parts[part_id] = PartEstimate(
                part_id, state.placement, part_centre(track, self.layout), confidence, state.age
            )
        held = sorted(
            (p for p in parts.values() if p.where is Where.HELD_BY_HUMAN),
            key=lambda p: -p.confidence,
        )
        unknown = sum(1 for p in parts.values() if p.where is Where.UNKNOWN)
        if held:
            human_confidence = held[0].confidence
        else:
            # Hands look free, unless a part we cannot see may be in them.
            human_confidence = 1.0 if unknown == 0 else 0.5
        key = tuple((pid, p.placement) for pid, p in parts.items())  # ids in sorted order
        self._age = self._age + 1 if key == self._last_key else 0
        self._last_key = key
        return WorldEstimate(
            frame_index,
            timestamp,
            parts,
            HumanEstimate(tuple(p.part_id for p in held), human_confidence),
            self._age,
            self._age >= self.settings.stable_frames,
        )
