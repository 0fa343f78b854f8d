"""Finding our QR codes in a frame with zxing-cpp (~ms a frame; it reads smaller
and more oblique codes than OpenCV's detectors)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
import zxingcpp

from perception.frames import Image
from perception.markers import MarkerCode, parse_payload

_QR = zxingcpp.BarcodeFormats(zxingcpp.BarcodeFormat.QRCode)
Corners = npt.NDArray[np.float64]  # 4 x 2 pixels: top-left, top-right, bottom-right, bottom-left


@dataclass(frozen=True)
class Detection:
    """One of our codes in an image. Corners are the symbol's outer corners in the
    code's own orientation (its top-left first, whatever way the code is turned)."""

    code: MarkerCode
    payload: str
    corners: Corners

    @property
    def centre(self) -> tuple[float, float]:
        c = self.corners.mean(axis=0)
        return (float(c[0]), float(c[1]))

    @property
    def side_px(self) -> float:
        """Mean edge length in pixels."""
        edges = np.roll(self.corners, -1, axis=0) - self.corners
        return float(np.linalg.norm(edges, axis=1).mean())


def decode_codes(image: Image) -> list[Detection]:
    """Our codes in a BGR (or grey) image; foreign and mirrored codes are dropped
    (a mirrored code is seen through glass or printed wrong: its pose would be too)."""
    gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    found = zxingcpp.read_barcodes(gray, formats=_QR, try_invert=False)
    out: list[Detection] = []
    seen: set[str] = set()
    for barcode in found:
        if not barcode.valid or barcode.text in seen:
            continue
        code = parse_payload(barcode.text)
        if code is None:
            continue
        p = barcode.position
        corners = np.array(
            [
                [p.top_left.x, p.top_left.y],
                [p.top_right.x, p.top_right.y],
                [p.bottom_right.x, p.bottom_right.y],
                [p.bottom_left.x, p.bottom_left.y],
            ],
            dtype=np.float64,
        )
        seen.add(barcode.text)
        out.append(Detection(code, barcode.text, corners))
    return out
