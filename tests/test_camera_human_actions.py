"""The human's actions timed by the camera: the simulated camera played in real time,
through the path a webcam's frames take (a `LiveCamera` thread, perception, the
watch of the human's actions), while a seeded simulated human moves parts over a
person's time; the execution runs on the wall clock. Every move the simulated
human really made is a `human` event of source camera whose start and end are
each within 0.3 s of the truth, a surprise too, and the robot's moves are none."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from app.execution.events import HUMAN, REPAIR, ExecutionEvent
from app.execution.repair import Repairer
from app.execution.timing import WallTimeline
from app.execution.walker import Executor
from app.responses.camera import camera_responses
from app.responses.sim_camera import SIM_SIZE, sim_scene
from app.sessions.store import SessionStore
from app.sim.hands import TrueMove
from app.sources.bench_layout import bench_layout
from app.sources.outcomes import FallbackSource, RandomSource
from perception.observe import BenchObserver, FrameObservation
from perception.part_moves import MoveSettings, MoveWatch, Pose, part_moves
from perception.pose import PartSighting
from perception.sim import Degradation, SimulatedCamera
from planner.scenario.loading import load_scenario
from tests.camera_runs import PutsItDownInstead
from tests.plan_fixtures import SCENARIOS, default_plan

TOLERANCE_S = 0.3
SEED = 0  # takes foot2, is asked where it attached it, takes leg2


def seen(part: str, at: float, x: float, yaw: float = 0.0) -> FrameObservation:
    sighting = PartSighting(part, 1, (x, 0.0, 0.8), (0.0, 0.0, 1.0), yaw, 40.0)
    return FrameObservation(round(at * 30), at, None, True, (), (sighting,))


def test_a_move_runs_from_the_last_frame_at_rest_to_the_first_still_one() -> None:
    # 30 fps: at rest until 1.0 s, moving 2 cm a frame until 1.5 s, then still.
    frames = []
    for i in range(90):
        at = i / 30
        x = 0.5 + 0.02 * min(max(0, i - 30), 15)
        frames.append((at, seen("leg1", at, x)))
    (move,) = part_moves(frames)
    assert move.part_id == "leg1" and move.ended == "settled"
    assert move.start == pytest.approx(30 / 30)  # the last frame at x 0.5
    assert move.end == pytest.approx(45 / 30)  # the first frame at x 0.8
    assert move.from_pose == Pose((0.5, 0.0, 0.8), 0.0)
    assert move.to_pose is not None and move.to_pose.position[0] == pytest.approx(0.8)


def test_scatter_a_bad_decode_and_a_hidden_part_are_no_moves() -> None:
    frames = []
    for i in range(60):
        at = i / 30
        x = 0.5 + 0.004 * math.sin(i)  # a still code's scatter
        if i == 20:
            x = 0.7  # one bad decode
        if 30 <= i < 50:
            continue  # a hand over the code, then it is there again
        frames.append((at, seen("top", at, x, yaw=0.02 * math.cos(i))))
    assert part_moves(frames, hand_x=1.0) == []


def test_a_slow_start_is_timed_from_its_last_still_frame_and_a_held_part_may_sway() -> None:
    # From 1.0 s the part speeds up from rest (a hand starting slowly): 5 mm after
    # 0.2 s, 2 cm after 0.4 s; it stops at 2.0 s.
    frames = []
    for i in range(90):
        at = i / 30
        t = min(max(0.0, at - 1.0), 1.0)
        frames.append((at, seen("leg2", at, 0.5 + 0.125 * t * t)))
    (move,) = part_moves(frames)
    assert move.start == pytest.approx(1.0 + 0.267, abs=0.02)  # last within 1 cm of rest
    assert move.end == pytest.approx(2.0, abs=0.04)
    # Held past the bench's edge, the part sways by 2 cm: no move.
    held, bench = MoveWatch(hand_x=1.5), MoveWatch()
    for i in range(90):
        sighting = seen("leg2", i / 30, 1.7 + 0.02 * math.sin(i / 3))
        assert held.update(sighting) == [] and bench.update(sighting) == []
    assert held.moving() == {}
    assert "leg2" in bench.moving()  # on the bench the same sway is a move, never settling


def test_a_part_gone_from_sight_ends_its_move_at_its_last_sighting() -> None:
    frames = [(i / 30, seen("foot1", i / 30, 0.5 + 0.03 * max(0, i - 10))) for i in range(20)]
    frames += [(i / 30, FrameObservation(i, i / 30, None, True, (), ())) for i in range(20, 50)]
    (move,) = part_moves(frames, MoveSettings())
    assert move.ended == "vanished" and move.to_pose is None
    assert (move.start, move.end) == (pytest.approx(10 / 30), pytest.approx(19 / 30))


def test_a_still_bench_in_noisy_frames_shows_no_move() -> None:
    """Rendered with blur, sensor noise, gain and light changes, every code's sighting
    scatters by a millimetre or two, now and then by metres (a frame whose camera
    pose is off): neither is a move."""
    scenario = load_scenario(SCENARIOS / "default.toml")
    layout = bench_layout(scenario)
    noisy = Degradation(blur_px=1.2, noise=6.0, gain=(0.85, 1.15), light_jitter=0.1, seed=1)
    watch = MoveWatch(hand_x=layout.human_side_x)
    with SimulatedCamera(sim_scene(scenario), size=SIM_SIZE, degradation=noisy) as camera:
        observer = BenchObserver(
            camera.intrinsics, layout.references, layout.marker_size_m, layout.bench_top_z
        )
        sightings = 0
        for _ in range(90):
            observation = observer.observe(camera.read())
            sightings += len(observation.sightings)
            assert watch.update(observation) == []
            assert watch.moving() == {}
    assert sightings > 180  # two codes a frame at least, of five


def match(truth: TrueMove, events: list[ExecutionEvent]) -> ExecutionEvent | None:
    """The camera's event of `truth`'s part whose start and end are nearest to it."""
    named = [e for e in events if f"moved {truth.part}," in (e.text or "")]

    def error(e: ExecutionEvent) -> float:
        assert e.start is not None and e.end is not None
        return max(abs(e.start - truth.start), abs(e.end - truth.end))

    return min(named, key=error, default=None)


def test_the_camera_times_each_human_action_in_real_time(tmp_path: Path) -> None:
    """The human takes a part, puts it down where the plan asks where it was attached
    (a surprise: the robot plans again), and takes and attaches parts after."""
    scenario = load_scenario(SCENARIOS / "default.toml")
    plan = default_plan()
    camera = camera_responses("sim", scenario, plan, SEED, real_time=True, human=PutsItDownInstead)
    assert isinstance(camera.human, PutsItDownInstead) and camera.human.world.hands is not None
    hands = camera.human.world.hands
    began = time.monotonic()
    with SessionStore(tmp_path) as store:
        executor = Executor(
            plan, FallbackSource(camera.source, RandomSource(SEED)), camera.listeners,
            timeline=WallTimeline(), repairing=Repairer(scenario, store.add_plan).repair,
        )  # fmt: skip
        try:
            assert executor.run() == "goal"
            hands.wait()
            time.sleep(1.0)  # the last move settles in the camera's view
        finally:
            camera.close()
    seconds = time.monotonic() - began
    assert camera.human.surprised_at is not None
    assert any(e.kind == REPAIR and e.source == "camera" for e in executor.events)
    truths = hands.moves
    assert {t.action for t in truths} == {"take", "putdown", "attach"}, truths
    observed = [e for e in executor.events if e.kind == HUMAN and e.source == "camera"]
    errors: list[tuple[str, float, float]] = []
    for truth in truths:
        event = match(truth, observed)
        assert event is not None, (truth, [e.text for e in observed])
        assert event.start is not None and event.end is not None
        errors.append((truth.part, event.start - truth.start, event.end - truth.end))
        assert abs(event.start - truth.start) <= TOLERANCE_S, (truth, event)
        assert abs(event.end - truth.end) <= TOLERANCE_S, (truth, event)
        assert event.evidence is not None and event.evidence.jpeg
    # Only the human's moves: the robot's holds, attaches and unholds are not kept.
    assert len(observed) == len(truths), [e.text for e in observed]
    assert camera.watch is not None and camera.watch.robots, "the robot moved no part in view"
    print(
        f"\n{len(truths)} human moves in a {seconds:.1f} s run; camera minus truth "
        f"(start, end) in s: {[(p, round(a, 3), round(b, 3)) for p, a, b in errors]}"
    )
