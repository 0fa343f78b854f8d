"""Where the bench's part labels stand so that none covers another on the screen.

Labels are drawn at a fixed size in pixels (viser's screen-space labels,
anchored at their top left), so whether two overlap depends on the camera,
not on how far apart the parts are: the default "Bench" camera looks at the
bench diagonally, and a part held up by the robot's right arm (nearer the
camera, higher) lands on the label of the assembly behind it. So the layout
projects every label through that camera, as a pinhole camera with viser's
75° vertical field of view, gives it a box of its text's size, and lifts a
label that meets one already placed until it is clear. Pure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

Point3 = tuple[float, float, float]
Pose = tuple[Point3, Point3]  # a camera's position, and the point it looks at

FOV_Y = math.radians(75.0)  # viser's default vertical field of view
# The narrowest page (800 px high): the labels' size in pixels, read off its screenshot.
PAGE_HEIGHT_PX = 800.0
CHAR_PX = 7.0
LINE_PX = 17.0
LIFT_M = 0.03  # a label meeting another goes up by this much at a time
# Up to 1.8 m: U10's 21 labels, with marker codes and "dangerous", need 1.2 m.
MAX_LIFTS = 60


Box = tuple[float, float, float, float]  # left, bottom, right, top, in pixels


def _unit(v: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    return v / float(np.linalg.norm(v))


class _Picture:
    """A camera's picture: its axes worked out once, then points projected with
    plain arithmetic (a layout projects hundreds of points per step)."""

    def __init__(self, camera: Pose) -> None:
        eye, target = np.array(camera[0], float), np.array(camera[1], float)
        forward = _unit(target - eye)
        right = _unit(np.cross(forward, (0.0, 0.0, 1.0)))
        up = np.cross(right, forward)
        self.eye = tuple(float(c) for c in eye)
        self.axes = [tuple(float(c) for c in axis) for axis in (right, up, forward)]
        self.focal = PAGE_HEIGHT_PX / (2 * math.tan(FOV_Y / 2))

    def box(self, anchor: Point3, text: str) -> Box:
        """The label's box on the picture (x right, y up, from its centre, at
        `PAGE_HEIGHT_PX`); an empty box for a label behind the camera."""
        offset = [a - e for a, e in zip(anchor, self.eye, strict=True)]
        across, up, depth = (sum(o * c for o, c in zip(offset, axis, strict=True))
                             for axis in self.axes)  # fmt: skip
        if depth <= 1e-6:
            return (0.0, 0.0, 0.0, 0.0)
        x, y = across * self.focal / depth, up * self.focal / depth
        return (x, y - LINE_PX, x + CHAR_PX * max(len(text), 1), y)


def label_box(camera: Pose, anchor: Point3, text: str) -> Box:
    """The label's box on `camera`'s picture (left, bottom, right, top), in pixels."""
    return _Picture(camera).box(anchor, text)


def _meets(a: Box, b: Box) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def laid_out(
    camera: Pose,
    anchors: Mapping[str, Point3],
    texts: Mapping[str, str],
    fixed: Sequence[tuple[Point3, str]] = (),
) -> dict[str, Point3]:
    """Label positions, lowest anchors first, where no label's box meets one
    placed before it, nor a `fixed` label (where, text), on `camera`'s picture
    (up to `MAX_LIFTS` lifts each)."""
    picture = _Picture(camera)
    placed: dict[str, Point3] = {}
    boxes = [picture.box(where, text) for where, text in fixed]
    for pid in sorted(anchors, key=lambda p: (anchors[p][2], p)):
        x, y, z = anchors[pid]
        text = texts.get(pid, pid)
        box = picture.box((x, y, z), text)
        for _ in range(MAX_LIFTS):
            if not any(_meets(box, other) for other in boxes):
                break
            z += LIFT_M
            box = picture.box((x, y, z), text)
        placed[pid] = (x, y, z)
        boxes.append(box)
    return placed
