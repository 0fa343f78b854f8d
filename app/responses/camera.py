"""`--responses camera:SOURCE`: the camera answers the sensing nodes of an execution.

`camera:sim` renders the scenario's bench with the simulated camera while a
seeded simulated human acts out the plan (it moves parts; the camera, not the
human, answers). Any other SOURCE is a real frame source (`webcam[:N]`, a
video file, an image folder) with a calibration's intrinsics, or the default of
its image size (app/sources/camera_input.py).
Nodes the camera cannot answer (questions, or no stable fit) fall back.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from app.execution.events import ExecutionEvent
from app.sim.human import SimulatedHuman, SimulatedWorld, StillSimulatedCamera
from app.sources.bench_layout import bench_layout, sim_scene
from app.sources.camera import CameraSource
from app.sources.camera_input import SIM_SIZE, open_camera
from perception.frames import FrameSource
from perception.intrinsics import CameraIntrinsics
from perception.pipeline import BenchPerception
from perception.sim import SimulatedCamera
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.model import Scenario


@dataclass
class CameraResponses:
    source: CameraSource
    listeners: list[Callable[[ExecutionEvent], None]]
    frames: FrameSource

    def close(self) -> None:
        self.frames.close()


def camera_responses(
    spec: str, scenario: Scenario, plan: Plan, seed: int | None,
    calibration: CameraIntrinsics | None = None,
) -> CameraResponses:
    """The camera source for `camera:SOURCE`; `SourceError` if the source cannot be opened."""
    layout = bench_layout(scenario)
    if spec == "sim":
        camera = StillSimulatedCamera(SimulatedCamera(sim_scene(scenario), size=SIM_SIZE))
        world = SimulatedWorld(part_boxes(scenario), layout, camera)
        human = SimulatedHuman(plan, world, seed)
        perception = BenchPerception(camera.camera.intrinsics, layout)
        return CameraResponses(CameraSource(camera, perception, human), [human.on_event], camera)
    real = open_camera(spec, scenario, calibration)
    perception = BenchPerception(real.intrinsics, layout)
    return CameraResponses(CameraSource(real.frames, perception), [], real.frames)
