"""A part's top-face outline from one frame: circle, square or triangle.

The code lies on the part's top face, or on a card flush with it beside the face
(a foot's face is smaller than a code), so the tracked code gives the face's
height, centre and turn. The frame is warped onto that plane: a top-down patch
at ~1 mm a pixel around the face, whatever the camera's angle. The face is the
region around its centre whose colour is nearer the centre's than the bench's
around it (the code's card masked out); its convex outline is then compared with
the ideal shapes by how much of its smallest enclosing rectangle and triangle it
fills, how round it is (circularity), and how many corners approxPolyDP keeps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from perception.frames import Image
from perception.intrinsics import CameraIntrinsics
from perception.pose import CameraPose

Vec3 = tuple[float, float, float]
Points = npt.NDArray[np.float32]
OUTLINES = ("circle", "square", "triangle")

# Each ideal outline's (circularity, fill of its enclosing rectangle, fill of its
# enclosing triangle); an equilateral triangle and a square for the polygons.
_IDEAL: dict[str, tuple[float, float, float]] = {
    "circle": (1.0, math.pi / 4, math.pi / (3 * math.sqrt(3))),
    "square": (math.pi / 4, 1.0, 0.5),
    "triangle": (math.pi * math.sqrt(3) / 9, 0.5, 1.0),
}
_CORNERS = {"triangle": 3, "square": 4}
_PATCH_PX = 160  # the patch's side at most; ~1 mm a pixel for faces up to 7 cm
_MARGIN = 1.1  # the patch reaches this many face widths either side of the centre
_CARD_GAP_M = 0.004  # masked around the code's card: its edge blurs into the face
_MIN_CONTRAST = 18.0  # grey levels between the face and the bench around it


@dataclass(frozen=True)
class FaceView:
    """Where a part's top face is: its centre in the bench frame (at the face's height),
    its turn about z, the footprint of its box (along its own x, y), and where its
    code's card lies on that plane (offset from the centre in its axes, side)."""

    centre: Vec3
    yaw: float
    footprint: tuple[float, float]
    code_offset: tuple[float, float]
    code_side: float


@dataclass(frozen=True)
class OutlineReading:
    """One frame's look at a face: the outline it fits best (None: no clear face),
    how clearly (0..1), and the measures that decided it."""

    shape: str | None
    confidence: float
    reason: str
    circularity: float = 0.0
    rect_fill: float = 0.0
    triangle_fill: float = 0.0
    corners: int = 0


def _project(points: npt.NDArray[np.float64], camera: CameraPose,
             intrinsics: CameraIntrinsics) -> npt.NDArray[np.float64]:
    r_cam = camera.rotation.T
    rvec, _ = cv2.Rodrigues(r_cam)
    tvec = -r_cam @ camera.position
    pixels, _ = cv2.projectPoints(points, rvec, tvec, intrinsics.matrix, intrinsics.dist_coeffs)
    return np.asarray(pixels, dtype=np.float64).reshape(-1, 2)


def face_patch(image: Image, face: FaceView, camera: CameraPose,
               intrinsics: CameraIntrinsics) -> tuple[Image, float] | None:
    """The frame warped onto the face's plane around its centre, the part's +x to the
    right and +y up, and its scale (pixels a metre); None when the face is behind
    the camera or out of the frame."""
    width = max(face.footprint)
    half = _MARGIN * width
    scale = min(1000.0, _PATCH_PX / (2 * half))
    n = round(2 * half * scale)
    c, s = math.cos(face.yaw), math.sin(face.yaw)
    local = np.array([[-half, half], [half, half], [half, -half], [-half, -half]])
    bench = np.array(
        [[face.centre[0] + c * a - s * b, face.centre[1] + s * a + c * b, face.centre[2]]
         for a, b in local]
    )
    cam_z = (camera.rotation.T @ (bench - camera.position).T)[2]
    if np.any(cam_z <= 0.05):
        return None
    pixels = _project(bench, camera, intrinsics)
    h, w = image.shape[:2]
    if pixels[:, 0].min() < 0 or pixels[:, 1].min() < 0 or pixels[:, 0].max() >= w \
            or pixels[:, 1].max() >= h:
        return None
    corners = np.array([[0, 0], [n, 0], [n, n], [0, n]], dtype=np.float32)
    to_image = cv2.getPerspectiveTransform(corners, pixels.astype(np.float32))
    patch = cv2.warpPerspective(
        image, to_image, (n, n), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return np.ascontiguousarray(patch), scale


def _card_mask(n: int, scale: float, face: FaceView) -> npt.NDArray[np.uint8]:
    """The code's card (and a thin margin) on the patch: not part of the face."""
    mask = np.zeros((n, n), np.uint8)
    dx, dy = face.code_offset
    half = face.code_side / 2 + _CARD_GAP_M
    centre = (n / 2 + dx * scale, n / 2 - dy * scale)
    box = cv2.boxPoints((centre, (2 * half * scale, 2 * half * scale), 0.0))
    cv2.fillConvexPoly(mask, np.round(box).astype(np.int32), 255)
    return mask


def _ring(n: int, inner: float, outer: float) -> npt.NDArray[np.bool_]:
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(xx - (n - 1) / 2, yy - (n - 1) / 2)
    return np.asarray((r >= inner) & (r <= outer), dtype=np.bool_)


def segment_face(patch: Image, scale: float, face: FaceView) -> tuple[Points | None, str]:
    """The face's outline on the patch (pixels), or None and why not."""
    n = patch.shape[0]
    colour = cv2.GaussianBlur(patch.astype(np.float32), (0, 0), 1.0)
    card = _card_mask(n, scale, face) > 0
    narrow = min(face.footprint) * scale
    seed_zone = _ring(n, 0, 0.12 * narrow) & ~card
    bench_zone = _ring(n, 0.85 * max(face.footprint) * scale, n / 2) & ~card
    if seed_zone.sum() < 3 or bench_zone.sum() < 10:
        return None, "the face is under its code's card"
    seed = np.median(colour[seed_zone], axis=0)
    bench = np.median(colour[bench_zone], axis=0)
    contrast = float(np.linalg.norm(bench - seed))
    if contrast < _MIN_CONTRAST:
        return None, "the face does not stand out from the bench"
    distance = np.linalg.norm(colour - seed, axis=2)
    inside = ((distance < contrast / 2) & ~card).astype(np.uint8)
    inside = cv2.morphologyEx(inside, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    count, labels = cv2.connectedComponents(inside, connectivity=8)
    if count < 2:
        return None, "no face at the code's part"
    overlap = np.bincount(labels[seed_zone], minlength=count)
    overlap[0] = 0
    label = int(overlap.argmax())
    if overlap[label] == 0:
        return None, "no face at the code's part"
    region = (labels == label).astype(np.uint8)
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(contours, key=cv2.contourArea)
    return outline.astype(np.float32), ""


def _expected_areas(footprint: tuple[float, float]) -> dict[str, float]:
    w, d = footprint
    side = min(w, d * 2 / math.sqrt(3))
    return {"square": w * d, "circle": math.pi * min(w, d) ** 2 / 4,
            "triangle": side * side * math.sqrt(3) / 4}


def classify_outline(outline: Points, scale: float,
                     footprint: tuple[float, float]) -> OutlineReading:
    """The ideal outline nearest to `outline`'s convex hull by circularity and
    enclosing-rectangle and enclosing-triangle fills; approxPolyDP's corners break
    near ties. Outlines far from the footprint's areas are no reading."""
    hull = cv2.convexHull(outline)
    area = float(cv2.contourArea(hull))
    perimeter = float(cv2.arcLength(hull, True))
    if area <= 4 or perimeter <= 0:
        return OutlineReading(None, 0.0, "no face outline")
    expected = _expected_areas(footprint)
    seen = area / scale**2
    if not 0.5 * min(expected.values()) <= seen <= 1.5 * max(expected.values()):
        ratio = seen / expected["square"]
        return OutlineReading(None, 0.0, f"the face is {ratio:.0%} of its box's: not clear")
    (_, _), (rw, rh), _ = cv2.minAreaRect(hull)
    triangle_area, _ = cv2.minEnclosingTriangle(hull)
    circularity = min(1.0, 4 * math.pi * area / perimeter**2)
    rect_fill = area / max(rw * rh, 1e-9)
    triangle_fill = area / max(float(triangle_area), 1e-9)
    corners = len(cv2.approxPolyDP(hull, 0.06 * perimeter, True))
    measured = np.array([circularity, rect_fill, triangle_fill])
    distances = {
        shape: float(np.linalg.norm(measured - np.array(ideal))) for shape, ideal in _IDEAL.items()
    }
    for shape, count in _CORNERS.items():
        if corners == count:
            distances[shape] *= 0.8  # the polygon's own corner count: a small pull
    ranked = sorted(distances, key=lambda k: distances[k])
    best, second = ranked[0], ranked[1]
    confidence = 1.0 - distances[best] / max(distances[second], 1e-9)
    return OutlineReading(
        best, confidence, f"{best}: circularity {circularity:.2f}, fills {rect_fill:.2f} "
        f"of a rectangle and {triangle_fill:.2f} of a triangle, {corners} corners",
        circularity, rect_fill, triangle_fill, corners,
    )


def read_outline(image: Image, face: FaceView, camera: CameraPose,
                 intrinsics: CameraIntrinsics) -> OutlineReading:
    """The outline of the face `face` describes, in one frame."""
    warped = face_patch(image, face, camera, intrinsics)
    if warped is None:
        return OutlineReading(None, 0.0, "the face is out of the frame")
    patch, scale = warped
    outline, why = segment_face(patch, scale, face)
    if outline is None:
        return OutlineReading(None, 0.0, why)
    return classify_outline(outline, scale, face.footprint)


@dataclass(frozen=True)
class OutlineEstimate:
    """What a part's face has looked like lately: the outline most of the recent
    looks read (None while none did), the share of the looks that read it, and how
    many looks the window holds."""

    shape: str | None
    confidence: float
    looks: int
