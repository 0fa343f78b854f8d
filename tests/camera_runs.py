"""One execution answered by the simulated camera while a seeded simulated human
acts out the plan (what `--responses camera:sim` wires up), for the camera tests."""

from __future__ import annotations

from app.execution.walker import Executor
from app.sim.human import SimulatedHuman, SimulatedWorld, StillSimulatedCamera
from app.sources.bench_layout import bench_layout, sim_scene
from app.sources.camera import CameraSource
from app.sources.camera_input import SIM_SIZE
from app.sources.outcomes import FallbackSource, RandomSource
from perception.pipeline import BenchPerception
from perception.sim import SimulatedCamera
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.model import Scenario


class CameraRun:
    def __init__(self, scenario: Scenario, plan: Plan, seed: int) -> None:
        layout = bench_layout(scenario)
        self.camera = StillSimulatedCamera(SimulatedCamera(sim_scene(scenario), size=SIM_SIZE))
        self.world = SimulatedWorld(part_boxes(scenario), layout, self.camera)
        self.human = SimulatedHuman(plan, self.world, seed)
        perception = BenchPerception(self.camera.camera.intrinsics, layout)
        self.source = CameraSource(self.camera, perception, self.human)
        self.executor = Executor(
            plan, FallbackSource(self.source, RandomSource(seed)), [self.human.on_event]
        )

    def close(self) -> None:
        self.camera.close()
