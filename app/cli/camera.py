"""`tandem camera calibrate SOURCE [--board 9x6] [--square M] -o calib.json`.

Reads frames of a printed chessboard (OpenCV's corner finder and calibration),
keeps views that differ from the ones kept (a board held still adds nothing),
and writes the intrinsics as JSON for `--calibration FILE` on `tandem track`
and `tandem execute`.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from app.cli.exit_codes import BadInput

DEFAULT_BOARD = "9x6"
DEFAULT_SQUARE_M = 0.025
MIN_SHIFT_PX = 15.0  # a view counts when its corners moved this far (mean) from every kept one


def register(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="camera_command", metavar="ACTION")
    calibrate = sub.add_parser(
        "calibrate", help="intrinsics from views of a chessboard, as JSON",
        description="intrinsics from views of a chessboard, as JSON",
    )  # fmt: skip
    calibrate.add_argument(
        "source",
        metavar="SOURCE",
        help="webcam[:INDEX], /dev/videoN, a video file or an image folder",
    )
    calibrate.add_argument(
        "--board",
        default=DEFAULT_BOARD,
        metavar="COLSxROWS",
        help=f"inner corners of the board (default {DEFAULT_BOARD})",
    )
    calibrate.add_argument(
        "--square",
        type=float,
        default=DEFAULT_SQUARE_M,
        metavar="M",
        help=f"side of a printed square, metres (default {DEFAULT_SQUARE_M})",
    )
    calibrate.add_argument(
        "--frames", type=int, default=600, help="read at most this many frames (default 600)"
    )
    calibrate.add_argument(
        "--views",
        type=int,
        default=25,
        help="calibrate with at most this many distinct views (default 25)",
    )
    calibrate.add_argument("-o", "--output", required=True, metavar="calib.json")
    calibrate.set_defaults(usage_of=calibrate, run=_calibrate)


def parse_board(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)x(\d+)", text)
    if match is None or min(int(match[1]), int(match[2])) < 3:
        raise BadInput(f"--board {text}: expected inner corners COLSxROWS, each 3 or more (9x6)")
    return int(match[1]), int(match[2])


def _calibrate(args: argparse.Namespace) -> int:
    board = parse_board(args.board)
    if not 0 < args.square < 1:
        raise BadInput(f"--square {args.square}: expected a side in metres, e.g. 0.025")
    if args.frames < 1 or args.views < 5:
        raise BadInput("--frames must be 1 or more and --views 5 or more")
    out = Path(args.output)
    if not out.parent.is_dir():
        raise BadInput(f"-o {args.output}: no folder {out.parent}")
    # Imported here: OpenCV is only needed by the camera commands.
    import numpy as np

    from perception.frames import SourceError, open_source
    from perception.intrinsics import CalibrationError, calibrate_views, find_chessboard

    try:
        frames = open_source(args.source)
    except SourceError as err:
        raise BadInput(f"{args.source}: {err}") from err
    views: list[np.ndarray] = []
    size = frames.size
    read = 0
    try:
        while read < args.frames and len(views) < args.views:
            frame = frames.read()
            if frame is None:
                break
            read += 1
            size = (frame.image.shape[1], frame.image.shape[0])
            corners = find_chessboard(frame.image, board)
            if corners is None:
                continue
            shifts = [float(np.abs(corners - v).mean()) for v in views]
            if all(s >= MIN_SHIFT_PX for s in shifts):
                views.append(corners)
    finally:
        frames.close()
    try:
        intrinsics, rms = calibrate_views(views, size, board, args.square)
    except CalibrationError as err:
        raise BadInput(f"{args.source}: {err} (board {args.board}, {read} frames read)") from err
    try:
        intrinsics.save(out)
    except OSError as err:
        raise BadInput(f"-o {args.output}: cannot write: {err.strerror or err}") from err
    print(
        f"{len(views)} views of {read} frames, RMS reprojection error {rms:.2f} px: "
        f"fx {intrinsics.fx:.1f} fy {intrinsics.fy:.1f} cx {intrinsics.cx:.1f} "
        f"cy {intrinsics.cy:.1f} ({intrinsics.width}x{intrinsics.height}, "
        f"{intrinsics.hfov_deg:.1f} deg across)"
    )
    print(out)
    return 0
