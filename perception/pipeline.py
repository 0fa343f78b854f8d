"""Frames to world estimates in one object: observe, track, estimate, and look at
the faces whose outline the layout leaves open."""

from __future__ import annotations

from dataclasses import dataclass, replace

from perception.frames import Frame
from perception.intrinsics import CameraIntrinsics
from perception.layout import BenchLayout
from perception.observe import BenchObserver, FrameObservation
from perception.outline_watch import OutlineWatch
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
        self.outlines = OutlineWatch(layout)

    def process(self, frame: Frame) -> Perceived:
        observation = self.observer.observe(frame)
        tracks = self.tracker.update(observation)
        world = self.estimator.update(tracks, frame.index, frame.timestamp)
        outlines = self.outlines.update(frame.image, observation)
        if outlines:
            parts = {
                pid: replace(est, outline=outlines[pid]) if pid in outlines else est
                for pid, est in world.parts.items()
            }
            world = replace(world, parts=parts)
        return Perceived(observation, world)
