"""`tandem markers`: the printed sheet carries every code of the scenario at its size."""

from __future__ import annotations

from pathlib import Path

import pytest
import zxingcpp
from PIL import Image

from app.cli.main import main
from perception.markers import encode_part, encode_reference
from perception.sheet import metres_to_px
from tests.plan_fixtures import SCENARIOS


def scenario_with_marker_size(tmp_path: Path, size: str) -> Path:
    text = (SCENARIOS / "default.toml").read_text()
    path = tmp_path / "small-codes.toml"
    path.write_text(text.replace("[goal]", f"[camera]\nmarker_size = {size}\n\n[goal]"))
    return path


def test_png_sheet_has_each_part_and_reference_at_the_scenarios_size(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = scenario_with_marker_size(tmp_path, "0.06")
    assert main(["markers", str(scenario), "-o", str(tmp_path / "sheet.png"), "--dpi", "200"]) == 0
    pages = [Path(line) for line in capsys.readouterr().out.splitlines()[1:]]
    assert pages and all(p.is_file() for p in pages)
    sides: dict[str, float] = {}
    for page in pages:
        for code in zxingcpp.read_barcodes(Image.open(page)):
            p = code.position
            sides[code.text] = (p.top_right.x - p.top_left.x + p.bottom_right.y - p.top_right.y) / 2
    parts = {"top": 1, "leg1": 2, "leg2": 3, "foot1": 4, "foot2": 5}
    expected = {encode_part(pid, m) for pid, m in parts.items()}
    expected |= {encode_reference(n) for n in ("near-left", "near-right", "far-left", "far-right")}
    assert set(sides) == expected
    want = metres_to_px(0.06, 200)
    assert all(abs(side - want) <= 2.5 for side in sides.values()), (sides, want)


def test_pdf_sheet_and_one_line_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["markers", "default.toml", "-o", str(tmp_path / "sheet.pdf")]) == 0
    assert (tmp_path / "sheet.pdf").read_bytes()[:5] == b"%PDF-"
    capsys.readouterr()
    assert main(["markers", "default.toml", "-o", str(tmp_path / "sheet.svg")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"-o {tmp_path / 'sheet.svg'}: expected a .pdf or .png file name"]
    bad = scenario_with_marker_size(tmp_path, "0.5")
    assert main(["markers", str(bad), "-o", str(tmp_path / "sheet.pdf")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.endswith("camera.marker_size: expected less than or equal to 0.16, got float 0.5")


def test_the_sheet_says_where_each_code_goes() -> None:
    from app.cli.markers import where_on_part

    assert where_on_part((0.09, 0.0)) == "top face, +9 cm x from the centre"
    assert where_on_part((0.0, -0.124)) == "top face, -12 cm y from the centre"
    assert where_on_part((0.0, 0.0)) == "centre of the top face"
    # Beside a face smaller than the code (a foot the camera must see): on a card.
    assert where_on_part((0.0, -0.09), (0.04, 0.04)) == (
        "on a card flush with the top face, -9 cm y from its centre"
    )
    assert where_on_part((0.09, 0.0), (0.30, 0.50)) == "top face, +9 cm x from the centre"
