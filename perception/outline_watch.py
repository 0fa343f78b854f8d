"""Each part's top-face outline across frames: a vote over the recent looks.

A part whose layout leaves its outline open (`PartShape.outline_unknown`) is
looked at in every frame that sees its code, at the face the code's track
places (`perception.outline`); one frame's reading may fail (blur, a hand, the
face under another part's card), so the estimate is the outline most of the
last `window` looks read, its confidence the share of the looks that read it.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Mapping
from functools import cache

from perception.codes_image import QUIET_ZONE_MODULES, modules_across
from perception.frames import Image
from perception.intrinsics import CameraIntrinsics
from perception.layout import BenchLayout
from perception.markers import encode_part
from perception.observe import FrameObservation
from perception.outline import FaceView, OutlineEstimate, OutlineReading, read_outline
from perception.tracking import Track
from perception.world import part_centre


@cache
def _card_side(part_id: str, marker_id: int, marker_size_m: float) -> float:
    """The printed square of a part's code, quiet zone included."""
    modules = modules_across(encode_part(part_id, marker_id))
    return marker_size_m * (modules + 2 * QUIET_ZONE_MODULES) / modules


class OutlineWatch:
    def __init__(self, layout: BenchLayout, window: int = 9) -> None:
        self.layout = layout
        self.window = window
        self._looks: dict[str, deque[str | None]] = {}
        self.last_readings: dict[str, OutlineReading] = {}

    def face(self, track: Track) -> FaceView | None:
        """Where the tracked part's top face is (None: not a part to look at)."""
        shape = self.layout.parts.get(track.part_id)
        if shape is None or not shape.outline_unknown:
            return None
        x, y, _ = part_centre(track, self.layout)
        side = _card_side(track.part_id, track.marker_id, self.layout.marker_size_m)
        return FaceView(
            (x, y, track.position[2]), track.yaw, (shape.size[0], shape.size[1]),
            shape.code_offset, side,
        )

    def update(
        self, image: Image, observation: FrameObservation, tracks: Mapping[str, Track],
        intrinsics: CameraIntrinsics,
    ) -> dict[str, OutlineEstimate]:
        camera = observation.camera
        for part_id, track in tracks.items():
            # Only a code seen in this frame puts the face where the frame shows it.
            seen_now = track.known and track.last_seen_index == observation.frame_index
            if camera is None or not seen_now:
                continue
            face = self.face(track)
            if face is None:
                continue
            reading = read_outline(image, face, camera, intrinsics)
            self.last_readings[part_id] = reading
            looks = self._looks.setdefault(part_id, deque(maxlen=self.window))
            looks.append(reading.shape)
        return {part_id: self.estimate(part_id) for part_id in self._looks}

    def estimate(self, part_id: str) -> OutlineEstimate:
        looks = self._looks.get(part_id)
        if not looks:
            return OutlineEstimate(None, 0.0, 0)
        votes = Counter(shape for shape in looks if shape is not None)
        if not votes:
            return OutlineEstimate(None, 0.0, len(looks))
        shape, count = votes.most_common(1)[0]
        return OutlineEstimate(shape, count / len(looks), len(looks))
