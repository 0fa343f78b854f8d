"""`--responses camera:SOURCE`: the camera answers the sensing nodes of an execution.

`camera:sim` renders the scenario's bench with the simulated camera while a
seeded simulated human acts out the plan (it moves parts; the camera, not the
human, answers). Any other SOURCE is a real frame source (`webcam[:N]`, a
video file, an image folder) with a calibration's intrinsics, or the default of
its image size (app/sources/camera_input.py).
Nodes the camera cannot answer (questions, or no stable fit) fall back.

`LiveAnswers` is the same for the dashboard's live camera: each execution gets
a camera source on the running camera's views, and with the simulated camera a
simulated human who acts out the clicks before the camera looks.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from app.execution.events import ExecutionEvent, OutcomeSource
from app.responses.sim_camera import open_sim_camera, sim_camera
from app.sim.human import DirectedHuman, SimulatedHuman, SimulatedWorld
from app.sources.bench_layout import bench_layout
from app.sources.camera import CameraSource
from app.sources.camera_feed import PulledFeed
from app.sources.camera_input import CameraInput, open_real_camera
from app.sources.live_camera import LiveCamera, live_source
from perception.frames import FrameSource, SourceError
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

    def close(self) -> None:
        self.frames.close()


def camera_responses(
    spec: str, scenario: Scenario, plan: Plan, seed: int | None,
    calibration: CameraIntrinsics | None = None,
) -> CameraResponses:
    """The camera source for `camera:SOURCE`; `SourceError` if the source cannot be opened."""
    layout = bench_layout(scenario)
    if spec != "sim":
        real = open_real_camera(spec, calibration)
        feed = PulledFeed(real.frames, BenchPerception(real.intrinsics, layout))
        return CameraResponses(CameraSource(feed), [], real.frames)
    camera = sim_camera(scenario)
    world = SimulatedWorld(part_boxes(scenario), layout, camera)
    human = SimulatedHuman(plan, world, seed)
    feed = PulledFeed(camera, BenchPerception(camera.camera.intrinsics, layout))
    return CameraResponses(CameraSource(feed, human), [human.on_event], camera)


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
            return live_source(live), []
        world = SimulatedWorld(part_boxes(live.scenario), live.layout, live)
        human = self.human(plan, world)
        return live_source(live, DirectedHuman(human, intent)), [human.on_event]
