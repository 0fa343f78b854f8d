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

Point3 = tuple[float, float, float]
Pose = tuple[Point3, Point3]  # a camera's position, and the point it looks at

FOV_Y = math.radians(75.0)  # viser's default vertical field of view
# The narrowest page (800 px high): the labels' size in pixels, read off its screenshot.
PAGE_HEIGHT_PX = 800.0
CHAR_PX = 7.0
LINE_PX = 17.0
LIFT_M = 0.03  # a label meeting another goes up by this much at a time
MAX_LIFTS = 30


def _image_point(camera: Pose, point: Point3) -> tuple[float, float] | None:
    """Where `point` lands in the camera's picture, in pixels from its centre
    (x right, y up), at `PAGE_HEIGHT_PX`; None behind the camera."""
    eye, target = np.array(camera[0]), np.array(camera[1])
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    offset = np.array(point) - eye
    depth = float(offset @ forward)
    if depth <= 1e-6:
        return None
    scale = PAGE_HEIGHT_PX / (2 * math.tan(FOV_Y / 2)) / depth
    return float(offset @ right) * scale, float(offset @ up) * scale


def label_box(camera: Pose, anchor: Point3, text: str) -> tuple[float, float, float, float]:
    """The label's box on the picture (left, bottom, right, top), in pixels; an
    empty box for a label behind the camera."""
    at = _image_point(camera, anchor)
    if at is None:
        return (0.0, 0.0, 0.0, 0.0)
    x, y = at
    return (x, y - LINE_PX, x + CHAR_PX * max(len(text), 1), y)


def _meets(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
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
    placed: dict[str, Point3] = {}
    boxes = [label_box(camera, where, text) for where, text in fixed]
    for pid in sorted(anchors, key=lambda p: (anchors[p][2], p)):
        x, y, z = anchors[pid]
        text = texts.get(pid, pid)
        box = label_box(camera, (x, y, z), text)
        for _ in range(MAX_LIFTS):
            if not any(_meets(box, other) for other in boxes):
                break
            z += LIFT_M
            box = label_box(camera, (x, y, z), text)
        placed[pid] = (x, y, z)
        boxes.append(box)
    return placed
