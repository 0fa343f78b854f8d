"""Each part's top-face outline across frames: a vote over the recent looks.

A part whose layout leaves its outline open (`PartShape.outline_unknown`) is
looked at in every frame that decodes its code, beside the code as the layout
says (`perception.outline`); one frame's reading may fail (blur, a hand, the
face under another part's card), so the estimate is the outline most of the
last `window` looks read, its confidence the share of the looks that read it.
"""

from __future__ import annotations

from collections import Counter, deque
from functools import cache

import numpy as np
import numpy.typing as npt

from perception.codes_image import printed_side
from perception.frames import Image
from perception.layout import BenchLayout
from perception.markers import PartCode, encode_part
from perception.observe import FrameObservation
from perception.outline import FaceView, OutlineEstimate, OutlineReading, read_outline


@cache
def _card_side(part_id: str, marker_id: int, marker_size_m: float) -> float:
    """The printed square of a part's code, quiet zone included (cached: every frame)."""
    return printed_side(encode_part(part_id, marker_id), marker_size_m)


# A code this much larger in the frame than another is nearer the camera.
_NEARER = 1.05


def _side_in_frame(corners: npt.NDArray[np.float64]) -> float:
    """A code's mean side in the frame, in pixels."""
    return float(np.mean(np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1)))


def _card_in_frame(corners: npt.NDArray[np.float64], ratio: float) -> npt.NDArray[np.float32]:
    """A code's card in the frame: its corners pushed out from its centre by `ratio`
    (the card's side, quiet zone included, over the code's)."""
    centre = corners.mean(axis=0)
    return np.asarray(centre + (corners - centre) * ratio, dtype=np.float32)


class OutlineWatch:
    def __init__(self, layout: BenchLayout, window: int = 9) -> None:
        self.layout = layout
        self.window = window
        self._looks: dict[str, deque[str | None]] = {}
        self.readings: dict[str, OutlineReading] = {}  # this frame's looks

    def face(self, part_id: str, marker_id: int) -> FaceView | None:
        """Where the part's top face lies from its code (None: not a part to look at)."""
        shape = self.layout.parts.get(part_id)
        if shape is None or not shape.outline_unknown:
            return None
        dx, dy = shape.code_offset
        marker = self.layout.marker_size_m
        return FaceView(
            (-dx, -dy), (shape.size[0], shape.size[1]), marker,
            _card_side(part_id, marker_id, marker),
        )

    def update(self, image: Image, observation: FrameObservation) -> dict[str, OutlineEstimate]:
        self.readings = {}
        marker = self.layout.marker_size_m
        cards = []  # every part code's side and card in the frame
        for d in observation.detections:
            if isinstance(d.code, PartCode):
                ratio = _card_side(d.code.part_id, d.code.marker_id, marker) / marker
                cards.append((d, _side_in_frame(d.corners), _card_in_frame(d.corners, ratio)))
        for detection in observation.detections:
            code = detection.code
            if not isinstance(code, PartCode):
                continue
            face = self.face(code.part_id, code.marker_id)
            if face is None:
                continue
            # Codes are printed at one size, so a code that looks larger is nearer the
            # camera: its card can lie over this face (a foot on a standing leg over
            # one on the bench), never under it.
            side = _side_in_frame(detection.corners)
            covers = [
                card
                for other, other_side, card in cards
                if other is not detection and other_side > _NEARER * side
            ]
            reading = read_outline(image, face, detection.corners, covers)
            self.readings[code.part_id] = reading
            looks = self._looks.setdefault(code.part_id, deque(maxlen=self.window))
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
