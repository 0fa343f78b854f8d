"""The whole simulated loop, headless: a seeded simulated human acts out the real plan
of the default scenario, the simulated camera renders the bench, perception decodes
every frame, and the camera answers every sensing node."""

from __future__ import annotations

import collections
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.execution.events import ExecutionEvent
from app.execution.walker import Executor
from app.responses.sim_camera import sim_scene
from app.sim.camera import StillSimulatedCamera
from app.sim.human import SimulatedHuman, SimulatedWorld
from app.sources.bench_layout import bench_layout, code_side, marker_ids, payloads
from app.sources.camera import CameraSource
from app.sources.camera_feed import PulledFeed
from app.sources.camera_reading import outcome_of
from app.sources.outcomes import FallbackSource, RandomSource
from perception import paper_bench
from perception.frames import Frame, VideoFileSource
from perception.pipeline import BenchPerception
from perception.sim import SimulatedCamera, write_video
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario
from planner.vocabulary import SenseHumanAttachingWhere, SenseHumanHolding
from tests.camera_runs import PutsItDownInstead
from tests.plan_fixtures import SCENARIOS, default_plan

SEEDS = range(20)
# 640 px renders in ~0.1 s (1024 px: ~0.3 s) and every code still decodes in a clean
# frame; the loop renders only when the world changed.
RENDER_SIZE = (640, 640)


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario(SCENARIOS / "default.toml")


@pytest.fixture(scope="module")
def plan() -> Plan:
    return default_plan()


class Run:
    def __init__(self, scenario: Scenario, plan: Plan, seed: int, record: bool = False) -> None:
        layout = bench_layout(scenario)
        self.camera = StillSimulatedCamera(SimulatedCamera(sim_scene(scenario), size=RENDER_SIZE))
        self.world = SimulatedWorld(part_boxes(scenario), layout, self.camera)
        self.human = SimulatedHuman(plan, self.world, seed)
        self.frames: list[Frame] | None = [] if record else None
        self.intrinsics = self.camera.camera.intrinsics
        perception = BenchPerception(self.intrinsics, layout)
        self.source = CameraSource(PulledFeed(self.camera, perception, self.frames), self.human)
        self.fallbacks: list[tuple[str, str]] = []
        self.executor = Executor(
            plan,
            FallbackSource(self.source, RandomSource(seed), self._fell_back),
            [self.human.on_event],
        )

    def _fell_back(self, node_id: str, reason: str) -> None:
        self.fallbacks.append((node_id, reason))

    def run(self) -> list[ExecutionEvent]:
        try:
            assert self.executor.run() == "goal"
        finally:
            self.camera.close()
        return self.executor.events


def test_layout_and_scene_agree_with_the_paper_bench(scenario: Scenario) -> None:
    ours, paper = bench_layout(scenario), paper_bench.layout()
    for field in ("regions", "bench_top_z", "bench_x", "bench_y", "human_side_x",
                  "references", "marker_size_m", "lift_split_x"):
        assert getattr(ours, field) == getattr(paper, field), field
    assert ours.parts.keys() == paper.parts.keys()
    for pid, shape in paper.parts.items():
        assert ours.parts[pid].size == shape.size
    top = ours.parts["top"]
    assert top.slots == paper.parts["top"].slots
    # The top's code at its edge towards the human: within 1 mm of the hand value.
    assert np.allclose(top.code_offset, paper.parts["top"].code_offset, atol=1e-3)
    # Legs have the foot point at their centre (the paper bench leaves it out), so
    # their code sits a code's width along them, clear of a foot's code.
    leg = ours.parts["leg1"]
    assert leg.slots == {"foot": (0.0, 0.0)}
    assert leg.code_offset[1] >= code_side(payloads(scenario)["leg1"], ours.marker_size_m)
    ours_scene, paper_scene = sim_scene(scenario), paper_bench.scene()
    assert ours_scene.references == paper_scene.references
    for a, b in zip(ours_scene.parts, paper_scene.parts, strict=True):
        assert (a.part_id, a.size, a.position, a.payload, a.yaw, a.colour) == (
            b.part_id, b.size, b.position, b.payload, b.yaw, b.colour
        )


def test_marker_ids_keep_the_scenarios_and_fill_the_rest_in_order(scenario: Scenario) -> None:
    assert marker_ids(scenario) == {"top": 1, "leg1": 2, "leg2": 3, "foot1": 4, "foot2": 5}
    parts = [scenario.parts[0].model_copy(update={"marker": 2}), *scenario.parts[1:]]
    renumbered = scenario.model_copy(update={"parts": parts})
    assert marker_ids(renumbered) == {"top": 2, "leg1": 1, "leg2": 3, "foot1": 4, "foot2": 5}


def test_the_camera_answers_every_sensing_node_as_the_human_acted(
    scenario: Scenario, plan: Plan
) -> None:
    seen: collections.Counter[tuple[str, str]] = collections.Counter()
    agree = total = 0
    start = time.perf_counter()
    for seed in SEEDS:
        run = Run(scenario, plan, seed)
        events = run.run()
        sensing = [e for e in events if e.kind == "sensing"]
        assert sensing, seed
        assert not [n for n, _ in run.fallbacks if plan.nodes[n].kind == "sensing"], seed
        for e in sensing:
            assert e.source == "camera", (seed, e)
            assert e.outcome == run.human.did[e.node], (seed, e, run.source.last_observation)
            assert e.confidence is not None and e.confidence > 0.5
            seen[(str(e.action).split("(")[1], str(e.outcome))] += 1
        a, t = run.human.agreement(events)
        agree, total = agree + a, total + t
        assert run.source.last_frame_jpeg is not None
        image = cv2.imdecode(np.frombuffer(run.source.last_frame_jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert image.shape[1] == 320
    elapsed = time.perf_counter() - start
    print(f"\n{len(SEEDS)} seeds: {agree}/{total} camera answers agree with the human, "
          f"{elapsed / len(SEEDS):.2f} s per seed; outcomes seen: {dict(seen)}")
    assert agree == total
    # The seeds reach both answers of the holding question and more than one part.
    assert seen[("humanHolding)", "yes")] and seen[("humanHolding)", "no")]
    assert len({label for (query, label) in seen if query == "humanHoldingWhichPart)"}) > 1


def test_a_recorded_video_gives_the_same_answers(
    scenario: Scenario, plan: Plan, tmp_path: Path
) -> None:
    seed = 2
    live = Run(scenario, plan, seed, record=True)
    live_events = live.run()
    assert live.frames
    path = tmp_path / "loop.avi"
    assert write_video(live.frames, path, fps=live.camera.fps) == len(live.frames)
    # The replay has no human: only the frames say what happened.
    video = VideoFileSource(path)
    perception = BenchPerception(live.intrinsics, bench_layout(scenario))
    replay_source = CameraSource(PulledFeed(video, perception))
    replay = Executor(plan, FallbackSource(replay_source, RandomSource(seed)))
    try:
        assert replay.run() == "goal"
    finally:
        video.close()

    def answers(events: list[ExecutionEvent]) -> list[tuple[str, str | None, str | None]]:
        return [(e.node, e.outcome, e.source) for e in events if e.kind == "sensing"]

    assert answers(replay.events) == answers(live_events)
    assert [e.node for e in replay.events] == [e.node for e in live_events]


def test_an_estimate_that_fits_no_option_is_a_surprise_once(
    scenario: Scenario, plan: Plan
) -> None:
    layout = bench_layout(scenario)
    with SimulatedCamera(sim_scene(scenario), size=RENDER_SIZE) as camera:
        world = SimulatedWorld(part_boxes(scenario), layout, camera)
        world.human_take("leg2")
        source = CameraSource(PulledFeed(camera, BenchPerception(camera.intrinsics, layout)))
        node_id, node = next(
            (i, n) for i, n in plan.nodes.items() if isinstance(n.action, SenseHumanHolding)
        )
        # The human holds leg2, but this node only offers "no": no outcome fits, and
        # what the camera saw is a surprise for the executor to plan from.
        surprised = source.choose(node_id, node, ["no"])
        assert surprised is not None and surprised.label == ""
        assert surprised.surprise is not None and str(surprised.surprise) == "take leg2"
        assert surprised.evidence is not None and surprised.evidence.jpeg
        obs = source.last_observation
        assert obs is not None and obs.label is None and obs.world is not None
        assert "leg2" in obs.reason
        assert outcome_of(node.action, obs.world, ["no", "yes"]).label == "yes"
        # Asked again at the same node (the executor could not follow it): no answer,
        # so the fallback decides instead of the camera repeating itself.
        assert source.choose(node_id, node, ["no"]) is None
        # A node that is not sensing is left to the fallback, without reading frames.
        ask_id, ask = next((i, n) for i, n in plan.nodes.items() if n.kind == "communication")
        frames = len(source.observations)
        assert source.choose(ask_id, ask, ask.outcomes) is None
        assert len(source.observations) == frames


def test_tandem_execute_with_the_simulated_camera(tmp_path: Path) -> None:
    from app.sessions.store import SessionStore
    from tests.plan_fixtures import tandem

    env = {**__import__("os").environ, "TANDEM_DATA_DIR": str(tmp_path)}
    done = tandem(
        "execute", "default.toml", "--responses", "camera:sim", "--human", "random",
        "--seed", "2", env=env,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1].split()[2] == "goal"
    with SessionStore(tmp_path) as store:
        (session,) = store.list_sessions()
        events = store.events(session.id, with_jpeg=True)
    sensing = [e for e in events if e.kind == "sensing"]
    assert sensing and all(e.source == "camera" for e in sensing)
    for e in sensing:
        # The deciding frame, what the camera read, and what the human really did.
        assert e.evidence is not None and e.evidence.jpeg is not None
        image = cv2.imdecode(np.frombuffer(e.evidence.jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert image is not None and image.shape[1] == 320
        camera = e.evidence.camera
        assert camera is not None and camera.decided == "label" and camera.value == e.outcome
        assert camera.frames >= 1 and camera.reason
        assert e.evidence.truth is not None and e.evidence.truth.label == e.outcome, e
    assert all(e.evidence is None for e in events if e.source != "camera")
    shown = tandem("sessions", "show", str(session.id), env=env)
    assert shown.returncode == 0, shown.stderr
    assert f"agree with the simulated human: {len(sensing)}/{len(sensing)}" in shown.stdout
    assert shown.stdout.count("(camera)") == len(sensing)
    assert shown.stdout.count(": agrees") == len(sensing)
    # No camera there: exit 2, the reason on the last line.
    done = tandem("execute", "default.toml", "--responses", "camera:webcam:63", env=env)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == "--responses camera:webcam:63: no camera at 63"


def test_what_the_camera_sees_against_the_plan_is_repaired(
    scenario: Scenario, plan: Plan, tmp_path: Path
) -> None:
    from app.execution.events import REPAIR
    from app.execution.repair import Repairer
    from app.sessions.store import SessionStore

    layout = bench_layout(scenario)
    camera = StillSimulatedCamera(SimulatedCamera(sim_scene(scenario), size=RENDER_SIZE))
    world = SimulatedWorld(part_boxes(scenario), layout, camera)
    # Seed 2 says "no, yes, leg2" and reaches a question of where leg2 went (n68).
    human = PutsItDownInstead(plan, world, seed=2)
    perception = BenchPerception(camera.camera.intrinsics, layout)
    source = CameraSource(PulledFeed(camera, perception), human)
    with SessionStore(tmp_path) as store:
        executor = Executor(
            plan, FallbackSource(source, RandomSource(2)), [human.on_event],
            repairing=Repairer(scenario, store.add_plan).repair,
        )
        try:
            assert executor.run() == "goal"
        finally:
            camera.close()
    assert human.surprised_at is not None, "the seed never reached an attaching question"
    (repair,) = [e for e in executor.events if e.kind == REPAIR]
    assert repair.node == human.surprised_at and repair.source == "camera"
    assert repair.evidence is not None and repair.evidence.replanned is not None
    assert repair.evidence.replanned.surprise.startswith("putdown")
    assert repair.text is not None and "I see you put the leg2 down" in repair.text
    asked = plan.nodes[repair.node].action
    assert isinstance(asked, SenseHumanAttachingWhere)
    # The new plan starts where the camera saw things: the part back on the bench.
    assert repair.plan is not None and executor.plan is repair.plan
    root = set(repair.plan.nodes[repair.plan.root].state)
    assert f"humanHoldingPart({asked.part})" not in root and "humanFree" in root
    assert not any(f.startswith(f"attached({asked.part},") for f in root)
