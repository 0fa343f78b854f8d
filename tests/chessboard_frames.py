"""Chessboard frames through a known pinhole camera (cv2 drawing + a perspective
warp), for calibration tests with the real OpenCV corner finder and calibration."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

SQUARE_PX = 40  # squares on the drawn board


def board_image(inner: tuple[int, int]) -> npt.NDArray[np.uint8]:
    """A board of (columns + 1) x (rows + 1) squares with a one-square white margin."""
    cols, rows = inner[0] + 1, inner[1] + 1
    board = np.full(((rows + 2) * SQUARE_PX, (cols + 2) * SQUARE_PX), 255, np.uint8)
    for r in range(rows):
        for c in range(cols):
            if (r + c) % 2 == 0:
                y, x = (r + 1) * SQUARE_PX, (c + 1) * SQUARE_PX
                board[y : y + SQUARE_PX, x : x + SQUARE_PX] = 0
    return board


def board_view(
    board: npt.NDArray[np.uint8], k: npt.NDArray[np.float64], rvec: npt.NDArray[np.float64],
    tvec: npt.NDArray[np.float64], square_m: float, size: tuple[int, int] = (640, 480),
) -> npt.NDArray[np.uint8]:
    """The board seen by a pinhole camera `k` at pose (rvec, tvec): a homography."""
    r, _ = cv2.Rodrigues(rvec)
    metres_per_px = square_m / SQUARE_PX
    h = k @ np.column_stack([r[:, 0], r[:, 1], tvec]) @ np.diag([metres_per_px, metres_per_px, 1])
    image = cv2.warpPerspective(board, h, size, flags=cv2.INTER_AREA, borderValue=180)
    return np.asarray(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR), dtype=np.uint8)


def board_views(
    k: npt.NDArray[np.float64], inner: tuple[int, int], square_m: float, count: int,
    size: tuple[int, int] = (640, 480), seed: int = 4,
) -> list[npt.NDArray[np.uint8]]:
    """`count` views of the board, tilted at random and kept in the frame."""
    rng = np.random.default_rng(seed)
    board = board_image(inner)
    width_m = (inner[0] + 3) * square_m  # the board with its margin
    height_m = (inner[1] + 3) * square_m
    views = []
    for _ in range(count):
        rvec = rng.normal(0, 0.35, 3)
        # The board's corner from the optical axis, so the board sits around the centre.
        x = rng.uniform(-0.6, -0.4) * width_m
        y = rng.uniform(-0.6, -0.4) * height_m
        z = rng.uniform(1.6, 2.2) * width_m * k[0, 0] / size[0]
        views.append(board_view(board, k, rvec, np.array([x, y, z]), square_m, size))
    return views
