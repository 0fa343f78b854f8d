"""The live camera loop without a browser: a thread reads the simulated camera at
30 fps, a seeded simulated human acts, the camera answers; what the camera sees
against the plan is a surprise the executor plans again from, as in a headless
run; frames that end leave the answer to the fallback. The camera sources import
no simulator: the simulated human acts through their `BeforeLook`."""

from __future__ import annotations

import ast
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.execution.events import REPAIR
from app.execution.repair import Repairer
from app.execution.walker import Executor
from app.responses.camera import LiveAnswers, open_camera
from app.sessions.store import SessionStore
from app.sim.camera import StillSimulatedCamera
from app.sim.human import SimulatedHuman, SimulatedWorld
from app.sources.camera import CameraSource
from app.sources.live_camera import LiveCamera, LiveFeed, live_source
from app.sources.outcomes import ExpectedSource, FallbackSource, RandomSource
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario
from planner.vocabulary import (
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
)
from tests.camera_runs import PutsItDownInstead
from tests.plan_fixtures import ROOT, SCENARIOS, default_plan


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario(SCENARIOS / "default.toml")


@pytest.fixture(scope="module")
def plan() -> Plan:
    return default_plan()


def simulated_live(scenario: Scenario) -> LiveCamera:
    camera = open_camera("sim", scenario)
    assert isinstance(camera.frames, StillSimulatedCamera)
    return LiveCamera(camera.frames, camera.intrinsics, scenario, name="sim",
                      simulated=camera.frames).start()  # fmt: skip


def test_live_answers_follow_the_humans_moves(scenario: Scenario, plan: Plan) -> None:
    live = simulated_live(scenario)
    try:
        world = SimulatedWorld(part_boxes(scenario), live.layout, live)
        human = SimulatedHuman(plan, world, seed=3)
        source = live_source(live, human)
        executor = Executor(plan, FallbackSource(source, RandomSource(3)), [human.on_event])
        assert executor.run() == "goal"
    finally:
        live.stop()
    sensing = [e for e in executor.events if e.kind == "sensing"]
    assert sensing and all(e.source == "camera" for e in sensing)
    assert human.agreement(executor.events) == (len(sensing), len(sensing))
    for e in sensing:
        assert e.evidence is not None and e.evidence.truth is not None
        assert e.evidence.truth.label == e.outcome
    # Each answer from the human's move: the render, and ~11 frames at 30 fps.
    answers = [o.seconds for o in source.observations if o.label is not None]
    assert len(answers) == len(sensing)
    assert max(answers) < 1.5, answers


def test_a_person_seen_against_the_plan_is_a_surprise(scenario: Scenario, plan: Plan) -> None:
    """No simulated human acts for the camera here: the parts are moved as a person
    at a real camera would, and the live views, not a click, say what happened."""
    live = simulated_live(scenario)
    try:
        world = SimulatedWorld(part_boxes(scenario), live.layout, live)
        world.human_take("leg2")
        source = live_source(live)
        node_id, node = next(
            (i, n) for i, n in plan.nodes.items() if isinstance(n.action, SenseHumanHolding)
        )
        # The human holds leg2, but this node only offers "no".
        surprised = source.choose(node_id, node, ["no"])
        assert surprised is not None and surprised.source == "camera"
        assert surprised.surprise is not None and str(surprised.surprise) == "take leg2"
        assert surprised.evidence is not None and surprised.evidence.jpeg
        assert surprised.evidence.camera is not None
        assert surprised.evidence.camera.decided == "surprise"
        assert surprised.evidence.camera.value == "take leg2"
        # Said once per node; the person putting it down then answers "no".
        assert source.choose(node_id, node, ["no"]) is None
        world.human_put_down("leg2")
        answered = source.choose(node_id, node, ["no"])
        assert answered is not None and answered.label == "no" and answered.surprise is None
    finally:
        live.stop()


def test_a_surprise_the_live_camera_sees_is_repaired(
    scenario: Scenario, plan: Plan, tmp_path: Path
) -> None:
    """The dashboard's wiring without the page: `LiveAnswers` gives an execution the
    camera source and a simulated human who acts out the intent (here the planner's
    expected outcomes, in the dashboard the clicks), and puts the part down where the
    plan asks where it was attached."""
    live = simulated_live(scenario)
    humans: list[PutsItDownInstead] = []

    def human(p: Plan, world: SimulatedWorld) -> SimulatedHuman:
        humans.append(PutsItDownInstead(p, world, seed=2))
        return humans[-1]

    try:
        source, listeners = LiveAnswers(live, human).for_execution(plan, ExpectedSource())
        with SessionStore(tmp_path) as store:
            executor = Executor(
                plan, FallbackSource(source, ExpectedSource()), listeners,
                repairing=Repairer(scenario, store.add_plan).repair,
            )  # fmt: skip
            assert executor.run() == "goal"
    finally:
        live.stop()
    (put_down,) = humans
    assert put_down.surprised_at is not None, "the plan never asked where a part went"
    (repair,) = [e for e in executor.events if e.kind == REPAIR]
    assert repair.node == put_down.surprised_at and repair.source == "camera"
    assert repair.evidence is not None and repair.evidence.replanned is not None
    assert repair.evidence.replanned.surprise.startswith("putdown")
    assert isinstance(plan.nodes[repair.node].action, SenseHumanAttachingWhere)
    assert repair.plan is not None and executor.plan is repair.plan


def test_frames_that_end_leave_the_answer_to_the_fallback(
    scenario: Scenario, plan: Plan, tmp_path: Path
) -> None:
    for i in range(2):
        cv2.imwrite(str(tmp_path / f"{i}.png"), np.full((120, 160, 3), 90, np.uint8))
    camera = open_camera(str(tmp_path), scenario)
    live = LiveCamera(camera.frames, camera.intrinsics, scenario, name="folder").start()
    node_id, node = next((i, n) for i, n in plan.nodes.items() if n.kind == "sensing")
    try:
        source = CameraSource(LiveFeed(live), max_frames=None, timeout_s=5.0)
        assert source.choose(node_id, node, node.outcomes) is None
        assert live.ended == "the frames ended"
        assert source.last_observation is not None
        assert source.last_observation.reason == "the frames ended"
        latest = live.latest()
        assert latest is not None and latest.seq == 2
        assert not latest.perceived.observation.detections
    finally:
        live.stop()


def test_an_interrupted_look_ends_at_once(scenario: Scenario, plan: Plan) -> None:
    """An abort while the camera watches for a person who has not acted yet (hands
    free where the plan asks which part they hold): no answer, long before the timeout."""
    live = simulated_live(scenario)
    node_id, node = next(
        (i, n) for i, n in plan.nodes.items() if isinstance(n.action, SenseHumanHoldingWhichPart)
    )
    try:
        source = live_source(live)
        threading.Timer(1.0, source.interrupt).start()
        start = time.monotonic()
        assert source.choose(node_id, node, node.outcomes) is None
        assert time.monotonic() - start < 5.0
        assert source.last_observation is not None
        assert source.last_observation.reason.endswith("(interrupted)")
        assert source.last_observation.frames > source.min_frames  # it was watching
    finally:
        live.stop()


def _imports(path: Path) -> set[str]:
    """Every module `path` imports, at its top, in a function or under TYPE_CHECKING."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module is not None:
            names.add(node.module)
    return names


def test_the_sources_import_no_simulator() -> None:
    """The simulated human acts through the sources' `BeforeLook`; the simulated camera
    is opened beside the simulators (app.responses): no source depends on them."""
    for path in sorted((ROOT / "app" / "sources").glob("*.py")):
        for name in _imports(path):
            assert not name.startswith(("app.sim", "perception.sim")), (path.name, name)
