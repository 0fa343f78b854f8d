"""Frames to world estimates in one object: observe, track, estimate."""

from __future__ import annotations

from dataclasses import dataclass

from perception.frames import Frame
from perception.intrinsics import CameraIntrinsics
from perception.layout import BenchLayout
from perception.observe import BenchObserver, FrameObservation
from perception.tracking import Tracker, TrackerSettings
from perception.world import WorldEstimate, WorldEstimator, WorldSettings


@dataclass(frozen=True)
class Perceived:
    observation: FrameObservation
    world: WorldEstimate


class BenchPerception:
    def __init__(
        self,
        intrinsics: CameraIntrinsics,
        layout: BenchLayout,
        tracker: TrackerSettings | None = None,
        world: WorldSettings | None = None,
    ) -> None:
        self.observer = BenchObserver(
            intrinsics, layout.references, layout.marker_size_m, layout.bench_top_z
        )
        self.tracker = Tracker(tracker)
        self.estimator = WorldEstimator(layout, world)

    def process(self, frame: Frame) -> Perceived:
        observation = self.observer.observe(frame)
        tracks = self.tracker.update(observation)
        world = self.estimator.update(tracks, frame.index, frame.timestamp)
        return Perceived(observation, world)
