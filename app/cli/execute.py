"""`tandem execute SCENARIO|PLAN.json`: run a plan, one branch, into the session store."""

from __future__ import annotations

import argparse
import secrets
import signal
import sys
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from app.cli.exit_codes import BadInput
from app.execution import ExecutionEvent, Executor
from app.outcomes import (
    ConsoleSource,
    ExpectedSource,
    FallbackSource,
    OutcomeSource,
    RandomSource,
    ScriptedSource,
)
from app.store import SessionStore
from planner.plan import Plan, PlanFormatError
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario import load_scenario
from planner.scenario_model import Scenario

if TYPE_CHECKING:  # OpenCV is loaded only for camera runs
    from perception.intrinsics import CameraIntrinsics


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="SCENARIO|PLAN.json", help="a scenario or a plan file")
    parser.add_argument(
        "--responses",
        default="click",
        help="where outcomes come from: click (numbered choices on stdin), random, "
        "scripted:FILE (one outcome label a line), or camera:SOURCE (the camera answers "
        "sensing; SOURCE is sim, webcam[:N], a video file or an image folder); default click",
    )
    parser.add_argument(
        "--human",
        choices=["random"],
        default="random",
        help="with camera:sim, how the simulated human acts (random, seeded by --seed)",
    )
    parser.add_argument("--seed", type=int, help="seed for --responses random or camera:sim")
    parser.add_argument(
        "--calibration", metavar="FILE",
        help="with a real camera: intrinsics from `tandem camera calibrate` (default: 60 deg)",
    )  # fmt: skip
    parser.add_argument("--data-dir", help="session store folder (default: $TANDEM_DATA_DIR, ...)")
    parser.add_argument(
        "--step-delay", type=float, default=0.0, help="seconds between steps (default 0)"
    )
    parser.add_argument("--note", help="a note stored with the session")
    parser.set_defaults(run=run)


def load_plan(target: str) -> tuple[Plan, Scenario | None]:
    """The plan of a plan file, or a fresh plan of a scenario file (with the scenario)."""
    path = Path(target)
    if path.suffix == ".json":
        try:
            return Plan.read(path), None
        except PlanFormatError as err:
            raise BadInput(str(err)) from err
    scenario = load_scenario(find_scenario(path))
    return plan_scenario(scenario, workers=1).plan, scenario


def make_source(spec: str, seed: int | None, plan: Plan) -> OutcomeSource:
    """The source for `--responses`; each falls back to the expected outcome."""
    primary: OutcomeSource
    if spec == "click":
        primary = ConsoleSource(sys.stdin, sys.stderr)
    elif spec == "random":
        primary = RandomSource(seed)
    elif spec.startswith("scripted:") and spec != "scripted:":
        scripted = ScriptedSource(spec[len("scripted:") :])
        scripted.check_labels(plan.outcome_labels())
        primary = scripted
    else:
        raise BadInput(f"--responses {spec}: expected click, random or scripted:FILE")

    def warn(node_id: str, reason: str) -> None:
        print(f"{node_id}: {reason}; taking the expected outcome", file=sys.stderr)

    return FallbackSource(primary, ExpectedSource(), on_fallback=warn)


def _camera_fallback(plan: Plan) -> Callable[[str, str], None]:
    # Questions are never the camera's to answer: only a sensing node it missed is news.
    def warn(node_id: str, reason: str) -> None:
        if plan.nodes[node_id].kind == "sensing":
            print(f"{node_id}: the camera did not answer ({reason}); a seeded choice",
                  file=sys.stderr)  # fmt: skip

    return warn


def _calibration(args: argparse.Namespace) -> CameraIntrinsics | None:
    if args.calibration is None:
        return None
    if not args.responses.startswith("camera:"):
        raise BadInput("--calibration goes with --responses camera:SOURCE")
    from app.camera_input import CalibrationFileError, load_calibration

    try:
        return load_calibration(args.calibration)
    except CalibrationFileError as err:
        raise BadInput(f"--calibration {err}") from err


def _print_event(event: ExecutionEvent) -> None:
    line = f"{event.seq:3d} {event.node:>5} {event.action or 'goal'}"
    if event.outcome is not None:
        line += f" -> {event.outcome} ({event.source})"
    if event.text:
        line += f"  {event.text}"
    print(line, file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    if args.step_delay < 0:
        raise BadInput(f"--step-delay {args.step_delay}: must be 0 or more")
    seeded = args.responses in ("random", "camera:sim")
    if args.seed is not None and not seeded:
        raise BadInput("--seed goes with --responses random or camera:sim")
    calibration = _calibration(args)  # before planning: a bad file is said at once
    plan, scenario = load_plan(args.input)
    seed = args.seed
    if seeded and seed is None:
        seed = secrets.randbelow(2**31)
        print(f"seed {seed}", file=sys.stderr)
    camera = None
    listeners: list[Callable[[ExecutionEvent], None]] = []
    if args.responses.startswith("camera:"):
        if scenario is None:
            raise BadInput("--responses camera:... needs the scenario file, not a plan file")
        # Imported here: the simulated camera loads pybullet, which other runs never need.
        from app.camera_responses import camera_responses
        from perception.frames import SourceError

        try:
            camera = camera_responses(
                args.responses[len("camera:") :], scenario, plan, seed, calibration
            )
        except SourceError as err:
            raise BadInput(f"--responses {args.responses}: {err}") from err
        listeners = camera.listeners
        source: OutcomeSource = FallbackSource(
            camera.source, RandomSource(seed), on_fallback=_camera_fallback(plan)
        )
    else:
        source = make_source(args.responses, seed, plan)
    note = args.note
    if seeded:
        note = f"seed {seed}" + (f"; {note}" if note else "")
    with SessionStore(args.data_dir) as store:
        session_id = store.start(plan, note=note)
        print(f"session {session_id}", flush=True)
        executor = Executor(
            plan,
            source,
            [store.recorder(session_id), *listeners, _print_event],
            args.step_delay,
        )

        def stop(signum: int, frame: FrameType | None) -> None:
            raise KeyboardInterrupt

        previous = signal.signal(signal.SIGTERM, stop)
        try:
            result = executor.run()
        except KeyboardInterrupt:
            result = "interrupted"
        finally:
            signal.signal(signal.SIGTERM, previous)
        store.finish(session_id, result)
    if camera is not None:
        camera.close()
    print(f"session {session_id}: {result} after {len(executor.events)} steps")
    return 0 if result == "goal" else 1
