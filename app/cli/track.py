"""`tandem track SOURCE --scenario S [--frames N] [--json] [--calibration FILE]`.

Runs perception on a camera's frames and prints each part's placement whenever
it changes (on the bench in a region, in the human's or the robot's hands,
attached at a slot, unknown): text lines, or one JSON object a line. A summary
(frames, time per frame, where the reference codes put the camera) goes to
stderr at the end.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.cli.exit_codes import BadInput
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario

if TYPE_CHECKING:  # OpenCV is loaded only when the command runs
    from perception.frames import Frame
    from perception.world import WorldEstimate


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "source", metavar="SOURCE",
        help="webcam[:INDEX], /dev/videoN, a video file, an image folder, or sim",
    )  # fmt: skip
    parser.add_argument("--scenario", required=True, help="the bench and its parts")
    parser.add_argument("--frames", type=int, help="stop after N frames (sim: default 30)")
    parser.add_argument("--json", action="store_true", help="one JSON object a change")
    parser.add_argument(
        "--calibration",
        metavar="FILE",
        help="intrinsics from `tandem camera calibrate` (default: 60 deg)",
    )
    parser.set_defaults(run=run)


def placement_json(part_id: str, estimate: Any, frame: int, seconds: float) -> dict[str, Any]:
    p = estimate.placement
    return {
        "frame": frame,
        "time": round(seconds, 3),
        "part": part_id,
        "where": str(p.where),
        "region": p.region,
        "attached_to": p.attached_to,
        "slot": p.slot,
        "position": None if estimate.position is None else [round(v, 3) for v in estimate.position],
        "confidence": round(estimate.confidence, 3),
    }


def run(args: argparse.Namespace) -> int:
    if args.frames is not None and args.frames < 1:
        raise BadInput(f"--frames {args.frames}: must be 1 or more")
    scenario = load_scenario(find_scenario(Path(args.scenario)))
    # Imported here: OpenCV (and pybullet for sim) only for the camera commands.
    from app.responses.camera import open_camera
    from app.sources.bench_layout import bench_layout
    from app.sources.camera_input import CalibrationFileError, load_calibration
    from perception.frames import SourceError
    from perception.pipeline import BenchPerception

    calibration = None
    if args.calibration is not None:
        try:
            calibration = load_calibration(args.calibration)
        except CalibrationFileError as err:
            raise BadInput(f"--calibration {err}") from err
    try:
        camera = open_camera(args.source, scenario, calibration, args.calibration or "")
    except SourceError as err:
        raise BadInput(f"{args.source}: {err}") from err
    limit = args.frames if args.frames is not None else (30 if args.source == "sim" else None)
    perception = BenchPerception(camera.intrinsics, bench_layout(scenario))
    shown: dict[str, object] = {}
    times: list[float] = []
    codes = 0
    try:
        while limit is None or len(times) < limit:
            frame = camera.frames.read()
            if frame is None:
                break
            start = time.perf_counter()
            perceived = perception.process(frame)
            times.append(time.perf_counter() - start)
            codes = len(perceived.observation.detections)
            _print_moves(perceived.world, frame, shown, as_json=args.json)
    except KeyboardInterrupt:
        pass  # a live camera runs until stopped
    finally:
        camera.close()
    if not times:
        raise BadInput(f"{args.source}: no frames")
    pose = perception.observer.camera
    # Where the reference codes put the camera: a check of its placement and intrinsics.
    where = (
        "not located (no reference code seen)"
        if pose is None
        else ("at x {:.3f} y {:.3f} z {:.3f} m".format(*pose.position))
    )
    median = statistics.median(times)
    print(
        f"{len(times)} frames, {codes} codes in the last, {median * 1e3:.1f} ms a frame "
        f"(median, {1 / median:.0f} fps); camera {where}; intrinsics: {camera.origin}",
        file=sys.stderr,
    )
    return 0


def _print_moves(
    world: WorldEstimate, frame: Frame, shown: dict[str, object], *, as_json: bool
) -> None:
    """A line for each part whose placement changed since it was last shown."""
    from app.sources.camera_reading import where_words

    for part_id, estimate in world.parts.items():
        if shown.get(part_id) == estimate.placement:
            continue
        shown[part_id] = estimate.placement
        if as_json:
            print(json.dumps(placement_json(part_id, estimate, frame.index, frame.timestamp)))
        else:
            print(
                f"frame {frame.index:5d} {frame.timestamp:7.2f} s  {part_id:>8} "
                f"{where_words(estimate.placement)} ({estimate.confidence:.2f})"
            )
        sys.stdout.flush()
