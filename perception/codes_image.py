"""QR symbols as Pillow images (drawn by segno), for printed sheets and textures."""

from __future__ import annotations

import io

import segno
from PIL import Image as PILImage

QUIET_ZONE_MODULES = 2  # zxing reads codes with a 2-module margin; 4 is the standard's


def qr_symbol(payload: str) -> segno.QRCode:
    # Error level L keeps short payloads at version 1 (21 modules): the largest
    # modules for a given printed size; segno raises the level when it is free.
    return segno.make_qr(payload, error="l", boost_error=True)


def modules_across(payload: str) -> int:
    """Modules along one side of the symbol, quiet zone excluded."""
    width, _ = qr_symbol(payload).symbol_size(scale=1, border=0)
    return int(width)


def printed_side(payload: str, marker_size_m: float) -> float:
    """The printed square of a code `marker_size_m` wide, its quiet zone included."""
    modules = modules_across(payload)
    return marker_size_m * (modules + 2 * QUIET_ZONE_MODULES) / modules


def qr_image(payload: str, module_px: int, border: int = QUIET_ZONE_MODULES) -> PILImage.Image:
    """The symbol as an RGB image, `module_px` pixels a module, `border` quiet modules."""
    buffer = io.BytesIO()
    qr_symbol(payload).save(buffer, kind="png", scale=module_px, border=border)
    buffer.seek(0)
    # segno writes 1-bit PNGs; pybullet and the sheet want RGB.
    return PILImage.open(buffer).convert("RGB")
