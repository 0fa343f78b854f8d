"""From code corners to positions in the bench frame.

The camera's pose comes from every visible reference code at once (one solvePnP
over all their corners, which are known on the bench); each part code's pose comes
from its own four corners (solvePnP IPPE_SQUARE) and is carried into the bench frame.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from perception.decode import Detection
from perception.intrinsics import CameraIntrinsics
from perception.markers import PartCode, ReferenceCode, ReferenceMarker

Matrix = npt.NDArray[np.float64]


@dataclass(frozen=True)
class CameraPose:
    """The camera in the bench frame: `rotation` has the camera's axes (OpenCV: x
    right, y down, z forward) as columns, `position` is its optical centre."""

    rotation: Matrix
    position: Matrix


@dataclass(frozen=True)
class PartSighting:
    """A part code seen in one frame, located in the bench frame."""

    part_id: str
    marker_id: int
    position: tuple[float, float, float]  # centre of the code = centre of the part's top face
    normal: tuple[float, float, float]  # the code's face direction (up when lying flat)
    yaw: float  # rotation of the code's rightward edge about z from +x, radians
    side_px: float  # apparent size: small codes give noisier positions


def _square(side: float) -> npt.NDArray[np.float64]:
    h = side / 2
    # IPPE_SQUARE's required order, matching zxing's corner order.
    return np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], dtype=np.float64)


def locate_camera(
    detections: Iterable[Detection],
    references: Sequence[ReferenceMarker],
    marker_size_m: float,
    bench_top_z: float,
    intrinsics: CameraIntrinsics,
) -> CameraPose | None:
    """The camera pose from the reference codes in view, or None if none is."""
    by_name = {r.name: r for r in references}
    world: list[npt.NDArray[np.float64]] = []
    pixels: list[npt.NDArray[np.float64]] = []
    for d in detections:
        if isinstance(d.code, ReferenceCode) and d.code.name in by_name:
            ref = by_name[d.code.name]
            world.append(_square(marker_size_m) + np.array([ref.x, ref.y, bench_top_z]))
            pixels.append(d.corners)
    if not world:
        return None
    obj = np.concatenate(world)
    img = np.concatenate(pixels)
    k, dist = intrinsics.matrix, intrinsics.dist_coeffs
    if len(world) == 1:
        ok, rvec, tvec = cv2.solvePnP(obj, img, k, dist, flags=cv2.SOLVEPNP_IPPE)
    else:
        ok, rvec, tvec = cv2.solvePnP(obj, img, k, dist, flags=cv2.SOLVEPNP_SQPNP)
        if ok:  # polish the global solution by Levenberg-Marquardt
            rvec, tvec = cv2.solvePnPRefineLM(obj, img, k, dist, rvec, tvec)
    if not ok:
        return None
    r_cam_bench, _ = cv2.Rodrigues(rvec)
    rotation = np.asarray(r_cam_bench, dtype=np.float64).T
    position = -rotation @ np.asarray(tvec, dtype=np.float64).reshape(3)
    return CameraPose(rotation, position)


def _flat_centre(
    corners: npt.NDArray[np.float64],
    camera: CameraPose,
    marker_size_m: float,
    intrinsics: CameraIntrinsics,
    reference_z: float,
) -> tuple[npt.NDArray[np.float64], float]:
    """Centre and yaw of a code lying face up at the height its apparent size gives.

    Back-projected onto a horizontal plane, the code's sides scale with the plane's
    distance from the camera, so one plane gives the true height in closed form. With
    the camera pose fixed by the references this is ~1 cm in height where a
    four-corner solvePnP is off by up to 3 cm (its tilt absorbs corner noise).
    """
    normalised = cv2.undistortPoints(
        corners.reshape(-1, 1, 2), intrinsics.matrix, intrinsics.dist_coeffs
    ).reshape(-1, 2)
    rays = (camera.rotation @ np.column_stack([normalised, np.ones(4)]).T).T
    c = camera.position

    def on_plane(z: float) -> npt.NDArray[np.float64]:
        return np.asarray(c + ((z - c[2]) / rays[:, 2])[:, None] * rays, dtype=np.float64)

    p = on_plane(reference_z)
    edges = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    diagonals = np.linalg.norm(p[[2, 3]] - p[[0, 1]], axis=1) / np.sqrt(2)
    side = float(np.concatenate([edges, diagonals]).mean())
    z = c[2] - (c[2] - reference_z) * marker_size_m / side
    p = on_plane(float(z))
    right = (p[1] - p[0]) + (p[2] - p[3])
    return p.mean(axis=0), float(np.arctan2(right[1], right[0]))


def locate_parts(
    detections: Iterable[Detection],
    camera: CameraPose,
    marker_size_m: float,
    intrinsics: CameraIntrinsics,
    reference_z: float = 0.0,
) -> list[PartSighting]:
    """Each part code's centre (assuming it lies face up, as codes on the top faces
    of lying, standing and carried parts do) and its face normal (solvePnP
    IPPE_SQUARE on its own corners) in the bench frame."""
    square = _square(marker_size_m)
    k, dist = intrinsics.matrix, intrinsics.dist_coeffs
    out: list[PartSighting] = []
    for d in detections:
        if not isinstance(d.code, PartCode):
            continue
        centre, yaw = _flat_centre(d.corners, camera, marker_size_m, intrinsics, reference_z)
        ok, rvecs, _, errors = cv2.solvePnPGeneric(
            square, d.corners, k, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
        )
        normal = np.array([0.0, 0.0, 1.0])
        if ok and len(rvecs):
            # IPPE gives two candidate poses for a square; the one that reprojects best.
            best = min(range(len(rvecs)), key=lambda i: float(np.asarray(errors).ravel()[i]))
            r_cam_code, _ = cv2.Rodrigues(rvecs[best])
            normal = (camera.rotation @ np.asarray(r_cam_code, dtype=np.float64))[:, 2]
        out.append(
            PartSighting(
                d.code.part_id,
                d.code.marker_id,
                (float(centre[0]), float(centre[1]), float(centre[2])),
                (float(normal[0]), float(normal[1]), float(normal[2])),
                yaw,
                d.side_px,
            )
        )
    return out
