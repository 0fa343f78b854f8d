"""Frame sources and their errors, intrinsics files, chessboard calibration on
boards rendered through a known camera."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from perception.frames import ImageFolderSource, SourceError, VideoFileSource, open_source
from perception.intrinsics import CameraIntrinsics, calibrate_chessboard
from tests.chessboard_frames import board_image, board_view

INNER = (8, 6)  # inner corners (columns, rows)
SQUARE_M = 0.03


def _one_line(error: pytest.ExceptionInfo[SourceError]) -> str:
    message = str(error.value)
    assert message and "\n" not in message
    return message


def test_no_camera_at_a_bad_index() -> None:
    with pytest.raises(SourceError) as error:
        open_source("webcam:63")
    assert "no camera" in _one_line(error)
    with pytest.raises(SourceError) as error:
        open_source("/dev/video63")
    assert "no camera" in _one_line(error)


def test_unreadable_video_file(tmp_path: Path) -> None:
    broken = tmp_path / "broken.mp4"
    broken.write_bytes(b"this is not a video" * 100)
    with pytest.raises(SourceError) as error:
        open_source(str(broken))
    assert "unreadable video" in _one_line(error)
    with pytest.raises(SourceError) as error:
        VideoFileSource(tmp_path / "missing.avi")
    assert "no video file" in _one_line(error)


def test_empty_folder(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("no images here")
    with pytest.raises(SourceError) as error:
        open_source(str(tmp_path))
    assert "no images" in _one_line(error)


def test_image_folder_reads_in_name_order(tmp_path: Path) -> None:
    for i in (2, 0, 1):
        cv2.imwrite(str(tmp_path / f"frame{i}.png"), np.full((48, 64, 3), i * 40, np.uint8))
    source = ImageFolderSource(tmp_path, fps=10)
    assert source.size == (64, 48)
    frames = [source.read() for _ in range(4)]
    assert frames[3] is None
    assert [int(f.image[0, 0, 0]) for f in frames if f] == [0, 40, 80]
    assert [f.timestamp for f in frames if f] == pytest.approx([0.0, 0.1, 0.2])


def test_intrinsics_json_round_trip_and_default(tmp_path: Path) -> None:
    default = CameraIntrinsics.from_fov(640, 480)
    assert default.hfov_deg == pytest.approx(60.0)
    assert default.fx == pytest.approx(320 / math.tan(math.radians(30)))
    default.save(tmp_path / "camera.json")
    assert CameraIntrinsics.load(tmp_path / "camera.json") == default


def test_calibration_recovers_focal_length() -> None:
    truth = CameraIntrinsics(560.0, 560.0, 322.0, 236.0, 640, 480)
    rng = np.random.default_rng(4)
    board = board_image(INNER)
    views = []
    for _ in range(10):
        rvec = rng.normal(0, 0.35, 3)
        x, y = rng.uniform(-0.18, -0.08), rng.uniform(-0.14, -0.06)
        tvec = np.array([x, y, rng.uniform(0.45, 0.6)])
        views.append(board_view(board, truth.matrix, rvec, tvec, SQUARE_M))
    found, rms = calibrate_chessboard(views, INNER, SQUARE_M)
    assert rms < 1.0
    assert found.fx == pytest.approx(truth.fx, rel=0.03)
    assert found.fy == pytest.approx(truth.fy, rel=0.03)
    assert found.cx == pytest.approx(truth.cx, abs=15)
    assert found.cy == pytest.approx(truth.cy, abs=15)
