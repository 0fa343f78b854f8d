"""`tandem markers SCENARIO -o FILE.pdf|FILE.png`: the scenario's printable codes.

One QR code per part (its id and the scenario's marker id) and the four reference
codes that fix the bench frame, at the scenario's `[camera] marker_size`, on A4
pages to print at 100 %.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from app.cli.exit_codes import BadInput
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario

SUFFIXES = (".pdf", ".png")


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="SCENARIO", help="a scenario file or a shipped name")
    parser.add_argument(
        "-o", "--output", required=True, metavar="FILE.pdf|FILE.png",
        help="the sheet: one PDF with every page, or PNG pages (FILE-2.png, ...)",
    )  # fmt: skip
    parser.add_argument("--dpi", type=int, default=300, help="print resolution (default 300)")
    parser.set_defaults(run=run)


def where_on_part(
    offset: tuple[float, float], face: tuple[float, float] | None = None
) -> str:
    """Where a part's code goes (perception reads the part's centre from it), in the
    part's own axes: the bench's, for a part lying as the scenario puts it. With the
    top face's size, a code centred off the face goes on a card flush with it."""
    shifts = [
        f"{v * 100:+.0f} cm {axis}" for v, axis in zip(offset, "xy", strict=True) if abs(v) >= 0.005
    ]
    if not shifts:
        return "centre of the top face"
    if face is not None and (abs(offset[0]) > face[0] / 2 or abs(offset[1]) > face[1] / 2):
        return f"on a card flush with the top face, {' '.join(shifts)} from its centre"
    return f"top face, {' '.join(shifts)} from the centre"


def run(args: argparse.Namespace) -> int:
    out = Path(args.output)
    if out.suffix.lower() not in SUFFIXES:
        raise BadInput(f"-o {args.output}: expected a .pdf or .png file name")
    if not 72 <= args.dpi <= 1200:
        raise BadInput(f"--dpi {args.dpi}: expected 72 to 1200")
    if not out.parent.is_dir():
        raise BadInput(f"-o {args.output}: no folder {out.parent}")
    scenario = load_scenario(find_scenario(Path(args.input)))
    # Imported here: the sheet and the bench layout pull in Pillow, segno and OpenCV,
    # which the other subcommands never need.
    from app.sources.bench_layout import bench_layout, marker_ids
    from perception.markers import PartCode
    from perception.sheet import render_marker_sheet

    layout = bench_layout(scenario)
    codes = [PartCode(pid, marker) for pid, marker in marker_ids(scenario).items()]
    notes = {
        pid: where_on_part(shape.code_offset, (shape.size[0], shape.size[1]))
        for pid, shape in layout.parts.items()
    }
    try:
        written = render_marker_sheet(
            codes, layout.references, layout.marker_size_m, out, dpi=args.dpi, notes=notes
        )
    except OSError as err:
        raise BadInput(f"-o {args.output}: cannot write: {err.strerror or err}") from err
    size_mm = layout.marker_size_m * 1000
    print(
        f"{len(codes)} part codes and {len(layout.references)} reference codes, "
        f"{size_mm:g} mm wide: print at 100 % (no fit to page); x points away from the "
        "robot, y to its left"
    )
    for path in written:
        print(path)
    return 0
