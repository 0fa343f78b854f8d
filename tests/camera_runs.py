"""One execution answered by the simulated camera while a seeded simulated human
acts out the plan (what `--responses camera:sim` wires up), for the camera tests;
and a simulated human who does, once, what the plan does not expect."""

from __future__ import annotations

from collections.abc import Sequence

from app.execution.walker import Executor
from app.responses.sim_camera import sim_camera
from app.sim.human import SimulatedHuman, SimulatedWorld
from app.sources.bench_layout import bench_layout
from app.sources.camera import CameraSource
from app.sources.camera_feed import PulledFeed
from app.sources.outcomes import FallbackSource, RandomSource
from perception.pipeline import BenchPerception
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan, PlanNode
from planner.scenario.model import Scenario
from planner.vocabulary import SenseHumanAttachingWhere


class CameraRun:
    def __init__(self, scenario: Scenario, plan: Plan, seed: int) -> None:
        layout = bench_layout(scenario)
        self.camera = sim_camera(scenario)
        self.world = SimulatedWorld(part_boxes(scenario), layout, self.camera)
        self.human = SimulatedHuman(plan, self.world, seed)
        perception = BenchPerception(self.camera.camera.intrinsics, layout)
        self.source = CameraSource(PulledFeed(self.camera, perception), self.human)
        self.executor = Executor(
            plan, FallbackSource(self.source, RandomSource(seed)), [self.human.on_event]
        )

    def close(self) -> None:
        self.camera.close()


class PutsItDownInstead(SimulatedHuman):
    """A simulated human who, at the first question of where they attached a part,
    puts that part back on the bench instead: what no branch of the plan expects."""

    surprised_at: str | None = None

    def act(
        self, node_id: str, node: PlanNode, options: Sequence[str], wanted: str | None = None
    ) -> str | None:
        if self.surprised_at is None and isinstance(node.action, SenseHumanAttachingWhere):
            self.surprised_at = node_id
            self.world.human_put_down(node.action.part)
            return None
        return super().act(node_id, node, options, wanted)
