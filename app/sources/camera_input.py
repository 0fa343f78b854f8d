"""Where a real camera's frames come from: a SOURCE spec and its intrinsics.

SOURCE is `webcam[:INDEX]`, `/dev/videoN`, a video file or a folder of images.
Real sources take the intrinsics of a calibration file (`tandem camera
calibrate`) or, without one, the documented default for their image size (a 60
degree horizontal field of view, the principal point at the centre, no
distortion). The simulated camera (`sim`) is opened beside the simulators, by
app.responses.camera.open_camera, which takes every SOURCE.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from perception.frames import FrameSource, open_source
from perception.intrinsics import CameraIntrinsics


class CalibrationFileError(ValueError):
    """A calibration file that cannot be read; the message is one line."""


@dataclass
class CameraInput:
    frames: FrameSource
    intrinsics: CameraIntrinsics
    origin: str  # where the intrinsics came from: "simulated", "default", or the file

    def close(self) -> None:
        self.frames.close()


def load_calibration(path: str | Path) -> CameraIntrinsics:
    try:
        intrinsics = CameraIntrinsics.load(path)
    except OSError as err:
        raise CalibrationFileError(f"{path}: cannot read: {err.strerror or err}") from err
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as err:
        raise CalibrationFileError(
            f"{path}: not a camera calibration (fx, fy, cx, cy, width, height): {err}"
        ) from err
    if min(intrinsics.fx, intrinsics.fy, intrinsics.width, intrinsics.height) <= 0:
        raise CalibrationFileError(f"{path}: focal lengths and image size must be positive")
    return intrinsics


def open_real_camera(
    spec: str,
    calibration: CameraIntrinsics | None = None,
    calibration_name: str = "",
) -> CameraInput:
    """The frames of a real camera, file or folder `spec`; `SourceError` (one line)
    when they cannot be read."""
    frames = open_source(spec)
    if calibration is not None:
        return CameraInput(frames, calibration, calibration_name or "calibration")
    width, height = frames.size
    return CameraInput(frames, CameraIntrinsics.from_fov(width, height), "default")
