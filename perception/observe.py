"""One frame in, its codes located in the bench frame out."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from perception.decode import Detection, decode_codes
from perception.frames import Frame
from perception.intrinsics import CameraIntrinsics
from perception.markers import ReferenceMarker
from perception.pose import CameraPose, PartSighting, locate_camera, locate_parts


@dataclass(frozen=True)
class FrameObservation:
    frame_index: int
    timestamp: float
    camera: CameraPose | None  # None until a reference code has been seen
    camera_fresh: bool  # the pose comes from this frame's references, not an earlier one
    detections: tuple[Detection, ...]
    sightings: tuple[PartSighting, ...]


class BenchObserver:
    """Decodes frames and locates part codes. The camera is fixed, so when no
    reference is visible (a hand over them) the last pose found is kept."""

    def __init__(
        self,
        intrinsics: CameraIntrinsics,
        references: Sequence[ReferenceMarker],
        marker_size_m: float,
        bench_top_z: float,
    ) -> None:
        self.intrinsics = intrinsics
        self.references = tuple(references)
        self.marker_size_m = marker_size_m
        self.bench_top_z = bench_top_z
        self.camera: CameraPose | None = None

    def observe(self, frame: Frame) -> FrameObservation:
        intrinsics = self.intrinsics
        h, w = frame.image.shape[:2]
        if (w, h) != (intrinsics.width, intrinsics.height):
            intrinsics = intrinsics.scaled(w, h)
        detections = decode_codes(frame.image)
        camera = locate_camera(
            detections, self.references, self.marker_size_m, self.bench_top_z, intrinsics
        )
        fresh = camera is not None
        if camera is not None:
            self.camera = camera
        sightings: list[PartSighting] = []
        if self.camera is not None:
            sightings = locate_parts(
                detections, self.camera, self.marker_size_m, intrinsics, self.bench_top_z
            )
        return FrameObservation(
            frame.index, frame.timestamp, self.camera, fresh, tuple(detections), tuple(sightings)
        )
