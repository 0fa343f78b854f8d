"""`--responses camera:SOURCE`: the camera answers the sensing nodes of an execution.

`camera:sim` renders the scenario's bench with the simulated camera while a
seeded simulated human acts out the plan (it moves parts; the camera, not the
human, answers). Any other SOURCE is a real frame source (`webcam[:N]`, a
video file, an image folder) with a calibration's intrinsics, or the default of
its image size (app/sources/camera_input.py).
Nodes the camera cannot answer (questions, or no stable fit) fall back.

A webcam keeps watching in its own thread (a `LiveCamera`), and the human's
actions it sees are kept as `human` events (app/sources/camera_human.py); so does
the simulated camera played in real time (`real_time`), whose simulated human
then moves parts over a person's time. A video file or an image folder is read
when the camera looks, as fast as it decodes: its frames are no clock.

`LiveAnswers` is the same for the dashboard's live camera: each execution gets
a camera source on the running camera's views, and with the simulated camera a
simulated human who acts out the clicks before the camera looks.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from app.execution.events import ExecutionEvent, OutcomeSource
from app.responses.sim_camera import open_sim_camera, sim_camera
from app.runner.session import Answering
from app.sim.hands import PacedHands
from app.sim.human import DirectedHuman, SimulatedHuman, SimulatedWorld
from app.sources.bench_layout import bench_layout
from app.sources.camera import BeforeLook, CameraSource
from app.sources.camera_feed import PulledFeed
from app.sources.camera_human import HumanActionWatch
from app.sources.camera_input import CameraInput, open_real_camera
from app.sources.live_camera import LiveCamera, live_source
from app.sources.outcomes import FallbackSource, RandomSource
from perception.frames import FrameSource, SourceError, WebcamSource
from perception.intrinsics import CameraIntrinsics
from perception.pipeline import BenchPerception
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.model import Scenario

Listener = Callable[[ExecutionEvent], None]
# Who acts before the simulated camera looks, given the plan and the world.
HumanFactory = Callable[[Plan, SimulatedWorld], SimulatedHuman]


def open_camera(
    spec: str,
    scenario: Scenario | None = None,
    calibration: CameraIntrinsics | None = None,
    calibration_name: str = "",
) -> CameraInput:
    """The frames of SOURCE `spec`: `sim` (the scenario's bench, rendered by the
    simulated camera), `webcam[:INDEX]`, `/dev/videoN`, a video file or a folder of
    images; `SourceError` (one line) when they cannot be read."""
    if spec == "sim":
        if scenario is None:
            raise SourceError("the simulated camera needs a scenario")
        return open_sim_camera(scenario)
    return open_real_camera(spec, calibration, calibration_name)


@dataclass
class CameraResponses:
    source: CameraSource
    listeners: list[Listener]
    frames: FrameSource
    live: LiveCamera | None = None  # the camera that keeps watching, if it does
    watch: HumanActionWatch | None = None  # the human's actions it keeps
    human: SimulatedHuman | None = None  # with the simulated camera

    def close(self) -> None:
        if self.live is not None:
            self.live.stop()  # closes the frames too
        else:
            self.frames.close()
        if self.human is not None and self.human.world.hands is not None:
            self.human.world.hands.close()

    def answering(
        self, seed: int | None, on_fallback: Callable[[str, str], None] | None = None
    ) -> Answering:
        """A session's answers: the camera's, a seeded choice where it has none (a
        question, or a sensing node it did not see); `on_fallback` is told which."""
        source = FallbackSource(self.source, RandomSource(seed), on_fallback=on_fallback)
        return Answering(source, listeners=tuple(self.listeners), close=self.close)


def watched(
    live: LiveCamera, before: BeforeLook | None = None
) -> tuple[CameraSource, HumanActionWatch]:
    """The camera source of one execution on `live`, whose human actions it sees are
    kept as `human` events (add `watch.on_event` to the execution's listeners)."""
    watch = HumanActionWatch(live)
    return live_source(live, before, watch), watch


def camera_responses(
    spec: str,
    scenario: Scenario,
    plan: Plan,
    seed: int | None,
    calibration: CameraIntrinsics | None = None,
    *,
    real_time: bool = False,
    human: Callable[[Plan, SimulatedWorld, int | None], SimulatedHuman] = SimulatedHuman,
) -> CameraResponses:
    """The camera source for `camera:SOURCE`; `SourceError` if the source cannot be
    opened. `real_time` plays the simulated camera as a webcam is read (for a run on
    the wall clock): in its own thread at 30 frames a second, while the simulated
    human's hands take their time. `human` makes the simulated human (a test may make
    one who does what the plan does not expect)."""
    layout = bench_layout(scenario)
    if spec != "sim":
        real = open_real_camera(spec, calibration)
        if isinstance(real.frames, WebcamSource):
            live = LiveCamera(real.frames, real.intrinsics, scenario, name=spec, pace_fps=None)
            source, watch = watched(live.start())
            return CameraResponses(source, [watch.on_event], real.frames, live, watch)
        feed = PulledFeed(real.frames, BenchPerception(real.intrinsics, layout))
        return CameraResponses(CameraSource(feed), [], real.frames)
    camera = sim_camera(scenario)
    if real_time:
        live = LiveCamera(camera, camera.camera.intrinsics, scenario, name="sim", simulated=camera)
        hands = PacedHands(live, seed)
        world = SimulatedWorld(part_boxes(scenario), layout, live, hands)
        actor = human(plan, world, seed)
        source, watch = watched(live.start(), actor)
        return CameraResponses(source, [actor.on_event, watch.on_event], camera, live, watch, actor)
    world = SimulatedWorld(part_boxes(scenario), layout, camera)
    actor = human(plan, world, seed)
    feed = PulledFeed(camera, BenchPerception(camera.camera.intrinsics, layout))
    return CameraResponses(CameraSource(feed, actor), [actor.on_event], camera, human=actor)


class LiveAnswers:
    """A running `LiveCamera` as the answers of the dashboard's executions (its
    stage's `CameraAnswers`). With the simulated camera each execution gets a new
    simulated world on the camera's bench and a human made by `human` (a test may
    make one who does what the plan does not expect), who acts out what the clicks
    choose; the camera then has to see it."""

    def __init__(self, live: LiveCamera, human: HumanFactory = SimulatedHuman) -> None:
        self.live = live
        self.name = live.name
        self.human = human

    def for_execution(
        self, plan: Plan, intent: OutcomeSource
    ) -> tuple[OutcomeSource, list[Listener]]:
        """The camera source for one run of `plan` and the listeners to add; `intent`
        (the clicks) says what a simulated human does."""
        live = self.live
        if live.simulated is None:
            source, watch = watched(live)
            return source, [watch.on_event]
        # The simulated human's hands take their time on the page's wall clock, as a
        # person's would: the camera times the moves it sees.
        hands = PacedHands(live)
        world = SimulatedWorld(part_boxes(live.scenario), live.layout, live, hands)
        human = self.human(plan, world)
        source, watch = watched(live, DirectedHuman(human, intent))
        return source, [human.on_event, watch.on_event]
