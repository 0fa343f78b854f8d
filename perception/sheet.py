"""Printable sheets of codes at true size (A4 pages, PNG or PDF by the suffix).

Printed at 100 % each symbol (quiet zone excluded) is `marker_size_m` wide; its label
is printed under it. Reference codes say where on the bench they belong.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from PIL import Image as PILImage
from PIL import ImageDraw, ImageFont

from perception.codes_image import QUIET_ZONE_MODULES, qr_image
from perception.markers import (
    DEFAULT_MARKER_SIZE_M,
    PartCode,
    ReferenceMarker,
    encode_part,
    encode_reference,
)

A4_M = (0.210, 0.297)
DEFAULT_DPI = 300
_MARGIN_M = 0.008
_LABEL_M = 0.012  # height of the label line under a code


def metres_to_px(metres: float, dpi: int) -> int:
    return round(metres / 0.0254 * dpi)


def _code(payload: str, side_px: int) -> PILImage.Image:
    # Drawn at one pixel a module by segno and scaled with nearest neighbour to the
    # exact printed size, so the size is right even when it is not a whole number
    # of pixels a module.
    img = qr_image(payload, module_px=1, border=0)
    return img.resize((side_px, side_px), PILImage.Resampling.NEAREST)


def render_marker_sheet(
    labels: Sequence[PartCode],
    reference_markers: Sequence[ReferenceMarker] = (),
    marker_size_m: float = DEFAULT_MARKER_SIZE_M,
    path: str | Path = "markers.pdf",
    dpi: int = DEFAULT_DPI,
    notes: Mapping[str, str] | None = None,
) -> list[Path]:
    """Draw every part code and reference code on A4 pages; returns the files written
    (a PDF holds all pages; PNG pages after the first are `<name>-2.png`, ...).
    `notes` adds words to a part's label (where on the part the code goes)."""
    path = Path(path)
    notes = notes or {}
    items = [
        (
            encode_part(c.part_id, c.marker_id),
            f"{c.part_id}  (marker {c.marker_id})"
            + (f": {notes[c.part_id]}" if c.part_id in notes else ""),
        )
        for c in labels
    ]
    items += [
        (encode_reference(r.name), f"ref {r.name} at x={r.x:.3f} y={r.y:.3f} m")
        for r in reference_markers
    ]
    page_w, page_h = metres_to_px(A4_M[0], dpi), metres_to_px(A4_M[1], dpi)
    side = metres_to_px(marker_size_m, dpi)
    quiet = max(round(side * QUIET_ZONE_MODULES / 21), 1)
    margin, label_h = metres_to_px(_MARGIN_M, dpi), metres_to_px(_LABEL_M, dpi)
    cell_w, cell_h = side + 2 * quiet, side + 2 * quiet + label_h
    cols = max((page_w - 2 * margin) // cell_w, 1)
    rows = max((page_h - 2 * margin) // cell_h, 1)
    if cell_w > page_w - 2 * margin or cell_h > page_h - 2 * margin:
        raise ValueError(f"a {marker_size_m} m code does not fit on an A4 page")
    font = ImageFont.load_default(size=max(label_h * 2 // 3, 8))
    pages: list[PILImage.Image] = []
    for i, (payload, text) in enumerate(items):
        slot = i % (cols * rows)
        if slot == 0:
            pages.append(PILImage.new("RGB", (page_w, page_h), "white"))
        row, col = divmod(slot, cols)
        x = margin + col * cell_w + quiet
        y = margin + row * cell_h + quiet
        page = pages[-1]
        page.paste(_code(payload, side), (x, y))
        ImageDraw.Draw(page).text((x, y + side + quiet // 2), text, fill="black", font=font)
    if not pages:
        raise ValueError("no codes to draw")
    written: list[Path] = []
    if path.suffix.lower() == ".pdf":
        pages[0].save(path, "PDF", resolution=float(dpi), save_all=True,
                      append_images=pages[1:])
        written.append(path)
    else:
        for n, page in enumerate(pages, start=1):
            target = path if n == 1 else path.with_name(f"{path.stem}-{n}{path.suffix}")
            page.save(target, dpi=(dpi, dpi))
            written.append(target)
    return written
