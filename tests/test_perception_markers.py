"""Payloads and printed marker sheets, decoded by the real zxing-cpp."""

from __future__ import annotations

from pathlib import Path

import pytest
import zxingcpp
from PIL import Image

from perception.markers import (
    PartCode,
    ReferenceCode,
    corner_references,
    encode_part,
    encode_reference,
    parse_payload,
)
from perception.sheet import metres_to_px, render_marker_sheet

PARTS = [PartCode("top", 1), PartCode("leg1", 2), PartCode("leg2", 3), PartCode("foot1", 4)]
REFERENCES = corner_references((0.30, 1.40), (-0.70, 0.70), 0.10)


def test_payloads_round_trip_and_foreign_codes_are_rejected() -> None:
    assert parse_payload(encode_part("leg1", 2)) == PartCode("leg1", 2)
    assert parse_payload(encode_reference("far-left")) == ReferenceCode("far-left")
    for foreign in ["https://example.org", "TDM:P:x:leg1", "TDM:Q:1", "XYZ:P:1:leg1", "TDM:P:1"]:
        assert parse_payload(foreign) is None, foreign
    with pytest.raises(ValueError):
        encode_part("bad:id", 1)


def test_reference_markers_sit_inside_the_bench_corners() -> None:
    assert len(REFERENCES) == 4
    for ref in REFERENCES:
        assert 0.30 + 0.05 <= ref.x <= 1.40 - 0.05
        assert -0.70 + 0.05 <= ref.y <= 0.70 - 0.05
    assert len({(round(r.x, 3), round(r.y, 3)) for r in REFERENCES}) == 4


@pytest.mark.parametrize("size_m", [0.05, 0.10])
def test_png_sheet_decodes_at_true_printed_size(tmp_path: Path, size_m: float) -> None:
    dpi = 300
    pages = render_marker_sheet(PARTS, REFERENCES, size_m, tmp_path / "sheet.png", dpi=dpi)
    found: dict[str, float] = {}
    for page in pages:
        image = Image.open(page)
        assert round(image.info["dpi"][0]) == dpi
        for code in zxingcpp.read_barcodes(image):
            p = code.position
            width, height = p.top_right.x - p.top_left.x, p.bottom_right.y - p.top_right.y
            found[code.text] = (width + height) / 2
    expected = {encode_part(c.part_id, c.marker_id) for c in PARTS}
    expected |= {encode_reference(r.name) for r in REFERENCES}
    assert set(found) == expected
    want_px = metres_to_px(size_m, dpi)
    for payload, side in found.items():
        # zxing's corners lie on the symbol's outer module edges, within a pixel or two.
        assert abs(side - want_px) <= 2.5, (payload, side, want_px)
        printed_mm = side / dpi * 25.4
        assert abs(printed_mm - size_m * 1000) < 0.3


def test_pdf_sheet_is_written(tmp_path: Path) -> None:
    (pdf,) = render_marker_sheet(PARTS, REFERENCES, 0.05, tmp_path / "sheet.pdf")
    head = pdf.read_bytes()[:5]
    assert head == b"%PDF-"
