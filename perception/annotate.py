"""A frame with what perception made of it drawn on: each decoded code boxed and
labelled (a part's id, a reference's name), and the bench's axes where the
reference codes put them. For live views and reviews; the frame is not changed."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import cv2
import numpy as np

from perception.decode import Detection
from perception.frames import Image
from perception.intrinsics import CameraIntrinsics
from perception.markers import PartCode
from perception.pose import CameraPose

PART_COLOUR = (40, 200, 40)  # BGR
REFERENCE_COLOUR = (220, 140, 0)
AXIS_COLOURS = ((0, 0, 230), (0, 190, 0), (230, 60, 0))  # x red, y green, z blue
AXIS_M = 0.15


def project(
    points: np.ndarray, camera: CameraPose, intrinsics: CameraIntrinsics
) -> np.ndarray:
    """Bench-frame points (N x 3) to pixels (N x 2)."""
    r_cam_bench = camera.rotation.T
    rvec, _ = cv2.Rodrigues(r_cam_bench)
    tvec = -r_cam_bench @ camera.position
    pixels, _ = cv2.projectPoints(
        np.asarray(points, dtype=np.float64), rvec, tvec, intrinsics.matrix,
        intrinsics.dist_coeffs,
    )
    return np.asarray(pixels, dtype=np.float64).reshape(-1, 2)


def annotate(
    image: Image,
    detections: Sequence[Detection],
    camera: CameraPose | None = None,
    intrinsics: CameraIntrinsics | None = None,
    axes_origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    labels: Mapping[str, str] | None = None,
    text_scale: float = 1.0,
) -> Image:
    """A copy of `image` with the codes and the bench axes (at `axes_origin`) drawn;
    `labels` may replace a part's id with longer words (its placement). `text_scale`
    enlarges the words for a picture that will be shown smaller than it is."""
    out = image.copy()
    scale = max(out.shape[1] / 640, 0.6)
    thickness = max(round(2 * scale), 1)
    font = 0.45 * scale * text_scale
    for d in detections:
        is_part = isinstance(d.code, PartCode)
        colour = PART_COLOUR if is_part else REFERENCE_COLOUR
        corners = np.round(d.corners).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [corners], True, colour, thickness, cv2.LINE_AA)
        if isinstance(d.code, PartCode):
            text = (labels or {}).get(d.code.part_id, d.code.part_id)
        else:
            text = d.code.name
        x, y = int(d.corners[:, 0].min()), int(d.corners[:, 1].min()) - 4
        (width, _), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, font, thickness)
        x = max(min(x, out.shape[1] - width - 2), 0)  # the words whole, inside the frame
        at = (x, max(y, round(12 * text_scale)))
        cv2.putText(out, text, at, cv2.FONT_HERSHEY_SIMPLEX, font, (0, 0, 0), thickness + 2,
                    cv2.LINE_AA)  # fmt: skip
        cv2.putText(out, text, at, cv2.FONT_HERSHEY_SIMPLEX, font, colour, thickness,
                    cv2.LINE_AA)  # fmt: skip
    if camera is not None and intrinsics is not None:
        h, w = out.shape[:2]
        if (w, h) != (intrinsics.width, intrinsics.height):
            intrinsics = intrinsics.scaled(w, h)
        o = np.array(axes_origin, dtype=np.float64)
        ends = np.vstack([o, o + np.eye(3) * AXIS_M])
        pixels = project(ends, camera, intrinsics)
        if np.all(np.isfinite(pixels)) and np.all(np.abs(pixels) < 4 * max(w, h)):
            start = tuple(int(v) for v in np.round(pixels[0]))
            for end, colour, name in zip(pixels[1:], AXIS_COLOURS, "xyz", strict=True):
                tip = tuple(int(v) for v in np.round(end))
                cv2.arrowedLine(out, start, tip, colour, thickness + 1, cv2.LINE_AA,
                                tipLength=0.2)  # fmt: skip
                cv2.putText(out, name, tip, cv2.FONT_HERSHEY_SIMPLEX, font * 10 / 9, colour,
                            thickness, cv2.LINE_AA)  # fmt: skip
    return out
