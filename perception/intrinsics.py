"""Camera intrinsics: a documented default, JSON files, chessboard calibration."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from perception.frames import Image

# A typical webcam's horizontal field of view; a guess good to ~10 % until calibrated.
DEFAULT_HFOV_DEG = 60.0


class CalibrationError(RuntimeError):
    """Too few chessboard views to calibrate; the message is one line."""


@dataclass(frozen=True)
class CameraIntrinsics:
    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    distortion: tuple[float, ...] = field(default=(0.0, 0.0, 0.0, 0.0, 0.0))

    @classmethod
    def from_fov(
        cls, width: int, height: int, hfov_deg: float = DEFAULT_HFOV_DEG
    ) -> CameraIntrinsics:
        """Square pixels, the principal point at the image centre, no distortion."""
        f = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
        return cls(f, f, (width - 1) / 2, (height - 1) / 2, width, height)

    @property
    def matrix(self) -> npt.NDArray[np.float64]:
        return np.array(
            [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64
        )

    @property
    def dist_coeffs(self) -> npt.NDArray[np.float64]:
        return np.array(self.distortion, dtype=np.float64)

    @property
    def hfov_deg(self) -> float:
        return math.degrees(2 * math.atan((self.width / 2) / self.fx))

    def scaled(self, width: int, height: int) -> CameraIntrinsics:
        """The same lens at another resolution (a capture that changed size)."""
        sx, sy = width / self.width, height / self.height
        return CameraIntrinsics(
            self.fx * sx, self.fy * sy, self.cx * sx, self.cy * sy, width, height, self.distortion
        )

    def to_json(self) -> str:
        return json.dumps(
            {
                "fx": self.fx,
                "fy": self.fy,
                "cx": self.cx,
                "cy": self.cy,
                "width": self.width,
                "height": self.height,
                "distortion": list(self.distortion),
            },
            indent=2,
        )

    @classmethod
    def from_json(cls, text: str) -> CameraIntrinsics:
        d = json.loads(text)
        return cls(
            float(d["fx"]),
            float(d["fy"]),
            float(d["cx"]),
            float(d["cy"]),
            int(d["width"]),
            int(d["height"]),
            tuple(float(v) for v in d.get("distortion", [0.0] * 5)),
        )

    def save(self, path: str | Path) -> None:
        Path(path).write_text(self.to_json() + "\n")

    @classmethod
    def load(cls, path: str | Path) -> CameraIntrinsics:
        return cls.from_json(Path(path).read_text())


def find_chessboard(image: Image, inner_corners: tuple[int, int]) -> npt.NDArray[np.float32] | None:
    """The board's inner corners refined to sub-pixel, or None if it is not seen."""
    gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    found, corners = cv2.findChessboardCorners(
        gray, inner_corners, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    )
    if not found:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 1e-3)
    refined = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), criteria)
    return np.asarray(refined, dtype=np.float32)


def board_points(inner_corners: tuple[int, int], square_m: float) -> npt.NDArray[np.float32]:
    """The board's inner corners in its own plane (metres), in OpenCV's order."""
    cols, rows = inner_corners
    board = np.zeros((rows * cols, 3), np.float32)
    board[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    return board


def calibrate_views(
    views: Sequence[npt.NDArray[np.float32]],
    size: tuple[int, int],
    inner_corners: tuple[int, int],
    square_m: float,
    min_views: int = 5,
) -> tuple[CameraIntrinsics, float]:
    """Intrinsics from the board corners found in `views` of `size` (width, height)
    pixels, and the RMS reprojection error in pixels."""
    if len(views) < min_views:
        raise CalibrationError(f"chessboard found in {len(views)} views, {min_views} needed")
    board = board_points(inner_corners, square_m)
    rms, matrix, dist, _, _ = cv2.calibrateCamera(
        [board] * len(views), list(views), size, np.eye(3), np.zeros(5)
    )
    m = np.asarray(matrix)
    intrinsics = CameraIntrinsics(
        float(m[0, 0]),
        float(m[1, 1]),
        float(m[0, 2]),
        float(m[1, 2]),
        size[0],
        size[1],
        tuple(float(v) for v in np.asarray(dist).ravel()),
    )
    return intrinsics, float(rms)


def calibrate_chessboard(
    images: Iterable[Image], inner_corners: tuple[int, int], square_m: float, min_views: int = 5
) -> tuple[CameraIntrinsics, float]:
    """Intrinsics from views of a chessboard with `inner_corners` (columns, rows) of
    squares `square_m` wide, and the RMS reprojection error in pixels."""
    views: list[npt.NDArray[np.float32]] = []
    size: tuple[int, int] | None = None
    for image in images:
        size = (image.shape[1], image.shape[0])
        corners = find_chessboard(image, inner_corners)
        if corners is not None:
            views.append(corners)
    if size is None:
        raise CalibrationError(f"no images: chessboard found in 0 views, {min_views} needed")
    return calibrate_views(views, size, inner_corners, square_m, min_views)
