"""Where frames come from: a webcam, a video file, a folder of images (and the
simulated camera in `perception.sim`), all behind one `FrameSource` protocol.

Every failure to open or read a source is a `SourceError` with a one-line message.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

import cv2
import numpy as np
import numpy.typing as npt

# FFmpeg writes its own complaint about a broken file ("moov atom not found") on
# stderr before OpenCV returns; the failure is reported once, as a SourceError. Read
# when OpenCV first opens a file, so set before that; the user's settings win.
os.environ.setdefault("OPENCV_FFMPEG_DEBUG", "1")
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET

Image = npt.NDArray[np.uint8]  # H x W x 3, BGR
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov", ".webm", ".m4v", ".mjpeg", ".mjpg")


class SourceError(RuntimeError):
    """A frame source cannot be opened or read; the message is one line."""


@dataclass(frozen=True)
class Frame:
    image: Image
    timestamp: float  # seconds: since the source opened (live) or the video's clock
    index: int  # 0, 1, 2... in the order the source gave the frames


@runtime_checkable
class FrameSource(Protocol):
    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        ...

    @property
    def fps(self) -> float: ...

    def read(self) -> Frame | None:
        """The next frame, or None when the source has ended."""
        ...

    def close(self) -> None: ...


class _CaptureSource:
    """Shared reading of cv2.VideoCapture devices and files."""

    def __init__(self, capture: cv2.VideoCapture, name: str, live: bool) -> None:
        self._capture = capture
        self._name = name
        self._live = live
        self._index = 0
        self._start = time.monotonic()
        fps = float(capture.get(cv2.CAP_PROP_FPS))
        self._fps = fps if fps > 0 else 30.0

    @property
    def size(self) -> tuple[int, int]:
        return (
            int(self._capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
            int(self._capture.get(cv2.CAP_PROP_FRAME_HEIGHT)),
        )

    @property
    def fps(self) -> float:
        return self._fps

    def read(self) -> Frame | None:
        ok, image = self._capture.read()
        if not ok or image is None:
            return None
        stamp = (
            time.monotonic() - self._start if self._live else self._index / self._fps
        )
        frame = Frame(np.ascontiguousarray(image, dtype=np.uint8), stamp, self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        self._capture.release()


class WebcamSource(_CaptureSource):
    def __init__(self, device: int | str = 0, size: tuple[int, int] | None = None) -> None:
        # OpenCV logs every backend it tried on stderr; a missing camera is reported
        # once, as a SourceError.
        level = cv2.utils.logging.getLogLevel()
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
        try:
            capture = cv2.VideoCapture(device)
        finally:
            cv2.utils.logging.setLogLevel(level)
        if size is not None and capture.isOpened():
            capture.set(cv2.CAP_PROP_FRAME_WIDTH, size[0])
            capture.set(cv2.CAP_PROP_FRAME_HEIGHT, size[1])
        if not capture.isOpened():
            capture.release()
            raise SourceError(f"no camera at {device!r}")
        super().__init__(capture, str(device), live=True)


class VideoFileSource(_CaptureSource):
    def __init__(self, path: str | Path) -> None:
        path = Path(path)
        if not path.is_file():
            raise SourceError(f"no video file at {path}")
        capture = cv2.VideoCapture(str(path))
        # A capture can open a broken file and only fail on the first read.
        ok = capture.isOpened() and capture.grab()
        capture.release()
        if not ok:
            raise SourceError(f"unreadable video file {path}")
        super().__init__(cv2.VideoCapture(str(path)), str(path), live=False)


class ImageFolderSource:
    """The images of a folder in name order, at a nominal frame rate."""

    def __init__(self, folder: str | Path, fps: float = 30.0) -> None:
        folder = Path(folder)
        if not folder.is_dir():
            raise SourceError(f"no image folder at {folder}")
        self._paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self._paths:
            raise SourceError(f"no images in folder {folder}")
        self._fps = fps
        self._index = 0
        first = self._load(self._paths[0])
        self._size = (first.shape[1], first.shape[0])

    @staticmethod
    def _load(path: Path) -> Image:
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise SourceError(f"unreadable image {path}")
        return np.ascontiguousarray(image, dtype=np.uint8)

    @property
    def size(self) -> tuple[int, int]:
        return self._size

    @property
    def fps(self) -> float:
        return self._fps

    def read(self) -> Frame | None:
        if self._index >= len(self._paths):
            return None
        image = self._load(self._paths[self._index])
        frame = Frame(image, self._index / self._fps, self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        self._index = len(self._paths)


def open_source(spec: str) -> FrameSource:
    """A source from its spec: ``webcam`` or ``webcam:INDEX``, ``/dev/videoN``, a
    video file, or a folder of images. (The simulated camera needs a world, so its
    owner builds a `perception.sim.SimulatedCamera` directly.)"""
    if spec == "webcam" or spec.startswith("webcam:"):
        index = spec.partition(":")[2] or "0"
        if not index.isdigit():
            raise SourceError(f"bad webcam index {index!r} in {spec!r}")
        return WebcamSource(int(index))
    if spec.startswith("/dev/video"):
        if not Path(spec).exists():
            raise SourceError(f"no camera at {spec}")
        return WebcamSource(spec)
    path = Path(spec)
    if path.is_dir():
        return ImageFolderSource(path)
    if path.suffix.lower() in VIDEO_SUFFIXES or path.is_file():
        return VideoFileSource(path)
    raise SourceError(f"no such source {spec!r} (webcam[:N], /dev/videoN, a video or a folder)")
