"""A part's top-face outline from one frame: circle, square or triangle.

The code lies on the part's top face, or on a card flush with it beside the face
(a foot's face is smaller than a code), so the code's four corners in the frame
give the face's plane, and the layout where the face lies on it. The frame is
warped onto that plane: a top-down patch at ~1 mm a pixel around the face,
whatever the camera's angle. The face is the region around its centre whose
colour is nearer the centre's than the bench's around it (the code's card masked
out; a tall part's sides cut off by a second, Otsu, threshold). Its convex
outline goes to the nearest ideal shape by how round it is (circularity) and how
much of its smallest enclosing rectangle and triangle it fills; the corners
approxPolyDP keeps break near ties.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from perception.frames import Image

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
_COVERED = 0.1  # the share of a face another part's card may hide and it is still read


@dataclass(frozen=True)
class FaceView:
    """Where a part's top face lies on its code's plane: its centre from the code's
    centre in the code's axes (x along the code's top edge, y up it), its box's
    footprint along those axes, the code's printed side (`marker_size`) and the
    side of its card, quiet zone included (masked: not part of the face)."""

    offset: tuple[float, float]
    footprint: tuple[float, float]
    marker_size: float
    card_side: float


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


def _code_to_image(face: FaceView, corners: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The homography from the code's plane (metres, the code's centre at 0) to the
    frame, from the code's four corners there (top-left first, as decoded)."""
    h = face.marker_size / 2
    code = np.array([[-h, h], [h, h], [h, -h], [-h, -h]], dtype=np.float32)
    return np.asarray(cv2.getPerspectiveTransform(code, corners.astype(np.float32)))


def face_patch(image: Image, face: FaceView,
               corners: npt.NDArray[np.float64]) -> tuple[Image, float] | None:
    """The frame warped onto the face's plane around its centre, the part's +x to the
    right and +y up, and its scale (pixels a metre); None when the patch leaves the
    frame. The plane comes from the code's four corners in this frame (top-left
    first, as decoded): exact for this frame whatever the camera's pose, where a
    tracked position and a kept camera pose lag a camera that moved."""
    to_image = _code_to_image(face, corners)
    half = _MARGIN * max(face.footprint)
    scale = min(1000.0, _PATCH_PX / (2 * half))
    n = round(2 * half * scale)
    ox, oy = face.offset
    # Patch pixels (u, v) to metres on the plane: x = ox + (u - n/2)/s, y = oy - (v - n/2)/s.
    to_plane = np.array(
        [[1 / scale, 0, ox - half], [0, -1 / scale, oy + half], [0, 0, 1]], dtype=np.float64
    )
    patch_to_image = to_image @ to_plane
    edges = np.array([[0, 0, 1], [n, 0, 1], [n, n, 1], [0, n, 1]], dtype=np.float64).T
    seen = patch_to_image @ edges
    if np.any(seen[2] <= 0):
        return None
    pixels = seen[:2] / seen[2]
    rows, cols = image.shape[:2]
    if pixels.min() < 0 or pixels[0].max() >= cols or pixels[1].max() >= rows:
        return None
    patch = cv2.warpPerspective(
        image, patch_to_image, (n, n), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return np.ascontiguousarray(patch), scale


def _card_mask(n: int, scale: float, face: FaceView) -> npt.NDArray[np.uint8]:
    """The code's card (and a thin margin) on the patch: not part of the face."""
    mask = np.zeros((n, n), np.uint8)
    ox, oy = face.offset  # the card is centred on the code, -offset from the face
    half = face.card_side / 2 + _CARD_GAP_M
    centre = (n / 2 - ox * scale, n / 2 + oy * scale)
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
    region = _component(((distance < contrast / 2) & ~card).astype(np.uint8), seed_zone)
    if region is None:
        return None, "no face at the code's part"
    # A tall part's sides lie beside its face on the patch and, lit almost like the
    # face, join it. A second, Otsu, cut inside the region parts them, kept when
    # what it cuts off holds a blob thicker than a blurred edge (a side, not a rim).
    values = distance[region > 0]
    cut, _ = cv2.threshold(np.clip(values, 0, 255).astype(np.uint8).reshape(-1, 1), 0,
                           255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    split = _component(((distance <= cut) & (region > 0)).astype(np.uint8), seed_zone)
    if split is not None:
        cut_off = ((region > 0) & (split == 0)).astype(np.uint8)
        thick = cv2.morphologyEx(cut_off, cv2.MORPH_OPEN, np.ones((5, 5), np.uint8))
        if thick.sum() > 0.1 * region.sum():
            region = split
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(contours, key=cv2.contourArea)
    return outline.astype(np.float32), ""


def _component(mask: npt.NDArray[np.uint8],
               seed_zone: npt.NDArray[np.bool_]) -> npt.NDArray[np.uint8] | None:
    """The opened mask's connected part that covers most of the seed zone."""
    opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    count, labels = cv2.connectedComponents(opened, connectivity=8)
    if count < 2:
        return None
    overlap = np.bincount(labels[seed_zone], minlength=count)
    overlap[0] = 0
    label = int(overlap.argmax())
    if overlap[label] == 0:
        return None
    return np.asarray(labels == label, dtype=np.uint8)


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


def face_in_frame(face: FaceView, corners: npt.NDArray[np.float64]) -> Points:
    """The face's footprint in the frame: four corners, from the code's plane."""
    to_image = _code_to_image(face, corners)
    (ox, oy), (w, d) = face.offset, face.footprint
    box = [[ox - w / 2, oy + d / 2], [ox + w / 2, oy + d / 2],
           [ox + w / 2, oy - d / 2], [ox - w / 2, oy - d / 2]]  # fmt: skip
    seen = cv2.perspectiveTransform(np.array([box], dtype=np.float32), to_image)
    return np.asarray(seen[0], dtype=np.float32)


def covered_share(face: Points, covers: Sequence[Points]) -> float:
    """The largest share of the face's footprint (frame pixels) one of `covers` hides."""
    area = float(cv2.contourArea(face))
    if area <= 0:
        return 0.0
    shares = [float(cv2.intersectConvexConvex(face, cover)[0]) / area for cover in covers]
    return max(shares, default=0.0)


def read_outline(
    image: Image, face: FaceView, corners: npt.NDArray[np.float64], covers: Sequence[Points] = ()
) -> OutlineReading:
    """The outline of the face beside the code whose corners are `corners`; `covers`
    are the cards of codes nearer the camera (in the frame), which may hide it."""
    if covers and covered_share(face_in_frame(face, corners), covers) > _COVERED:
        # Half a square reads as a triangle: a hidden face is no reading at all.
        return OutlineReading(None, 0.0, "the face is under another part's card")
    warped = face_patch(image, face, corners)
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
