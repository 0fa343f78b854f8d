"""The live camera loop without a browser: a thread reads the simulated camera at
30 fps, a seeded simulated human acts, the camera answers; frames that end leave
the answer to the fallback."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from app.execution.walker import Executor
from app.sim.human import SimulatedHuman, SimulatedWorld, StillSimulatedCamera
from app.sources.camera_input import open_camera
from app.sources.live_camera import LiveCamera, LiveCameraSource
from app.sources.outcomes import FallbackSource, RandomSource
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario
from tests.plan_fixtures import SCENARIOS, default_plan


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario(SCENARIOS / "default.toml")


@pytest.fixture(scope="module")
def plan() -> Plan:
    return default_plan()


def test_live_answers_follow_the_humans_moves(scenario: Scenario, plan: Plan) -> None:
    camera = open_camera("sim", scenario)
    assert isinstance(camera.frames, StillSimulatedCamera)
    live = LiveCamera(camera.frames, camera.intrinsics, scenario, name="sim",
                      simulated=camera.frames).start()  # fmt: skip
    try:
        world = SimulatedWorld(part_boxes(scenario), live.layout, live)
        human = SimulatedHuman(plan, world, seed=3)
        source = LiveCameraSource(live, human)
        executor = Executor(plan, FallbackSource(source, RandomSource(3)), [human.on_event])
        assert executor.run() == "goal"
    finally:
        live.stop()
    sensing = [e for e in executor.events if e.kind == "sensing"]
    assert sensing and all(e.source == "camera" for e in sensing)
    assert human.agreement(executor.events) == (len(sensing), len(sensing))
    for e in sensing:
        assert e.evidence is not None and e.evidence.detail["truth"] == e.outcome
    # Each answer from the human's move: the render, and ~11 frames at 30 fps.
    assert len(source.answer_seconds) == len(sensing)
    assert max(source.answer_seconds) < 1.5, source.answer_seconds


def test_frames_that_end_leave_the_answer_to_the_fallback(
    scenario: Scenario, plan: Plan, tmp_path: Path
) -> None:
    for i in range(2):
        cv2.imwrite(str(tmp_path / f"{i}.png"), np.full((120, 160, 3), 90, np.uint8))
    camera = open_camera(str(tmp_path), scenario)
    live = LiveCamera(camera.frames, camera.intrinsics, scenario, name="folder").start()
    node_id, node = next((i, n) for i, n in plan.nodes.items() if n.kind == "sensing")
    try:
        assert LiveCameraSource(live, timeout_s=5.0).choose(node_id, node, node.outcomes) is None
        assert live.ended == "the frames ended"
        latest = live.latest()
        assert latest is not None and latest.seq == 2
        assert not latest.perceived.observation.detections
    finally:
        live.stop()
