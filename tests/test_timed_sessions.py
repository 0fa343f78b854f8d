"""Time in the execution: every event has a start and an end, simulated in headless runs.

The robot's steps follow one another; the simulated human acts in its own time
after a request, while the robot goes on where the plan lets it, and a sensing
node that watches the human waits for it. The same seed gives the same timed
session; the store keeps the times, and an older store gets their columns.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from app.execution.events import HUMAN, ExecutionEvent
from app.execution.narration import RobotVoice
from app.execution.timing import (
    BAXTER_VELOCITY_LIMITS,
    CAMERA_SETTLE_S,
    SPEECH_WORDS_PER_S,
    SimulatedTimeline,
    WallTimeline,
    joint_velocity_limits,
    motion_seconds,
    watches_human,
)
from app.execution.walker import Executor
from app.sessions.metrics import ROBOT_KINDS
from app.sessions.store import SessionStore
from app.sources.outcomes import ExpectedSource, RandomSource
from planner.plan.model import Plan
from planner.scenario.sections import Human
from tests.plan_fixtures import default_plan, paper_plan

OLD_STORE = Path(__file__).parent / "fixtures" / "sessions-0.1.db"
SEEDS = range(24)


@pytest.fixture(scope="module")
def plan() -> Plan:
    return default_plan()


def simulated(plan: Plan, seed: int, human: Human | None = None) -> list[ExecutionEvent]:
    timeline = SimulatedTimeline(seed, human, origin=1_000.0)
    executor = Executor(plan, RandomSource(seed), timeline=timeline)
    assert executor.run() == "goal"
    return executor.events


def spans(events: list[ExecutionEvent], kinds: tuple[str, ...]) -> list[tuple[float, float]]:
    out = []
    for e in events:
        if e.kind in kinds:
            assert e.start is not None and e.end is not None
            out.append((e.start, e.end))
    return sorted(out)


def task_actions(events: list[ExecutionEvent]) -> list[ExecutionEvent]:
    """The human's task actions: its events less its answers to questions (talk, which
    end with the question they answer and may overlap a task action)."""
    answered = {(e.node, e.end) for e in events if e.kind != HUMAN and e.outcome is not None}
    return [e for e in events if e.kind == HUMAN and (e.node, e.end) not in answered]


def test_each_agent_does_one_thing_at_a_time(plan: Plan) -> None:
    for seed in SEEDS:
        events = simulated(plan, seed)
        for own_events in ([e for e in events if e.kind in ROBOT_KINDS], task_actions(events)):
            own = spans(own_events, tuple(ROBOT_KINDS) + (HUMAN,))
            assert all(start <= end for start, end in own)
            assert all(
                a_end <= b_start for (_, a_end), (b_start, _) in zip(own, own[1:], strict=False)
            )
        # `time` is when the event was recorded: its end.
        assert all(e.time == e.end for e in events)


def test_the_robot_goes_on_after_a_request_and_waits_where_it_watches(plan: Plan) -> None:
    overlapped = 0
    for seed in SEEDS:
        events = simulated(plan, seed)
        steps = [e for e in events if e.kind in ROBOT_KINDS]
        for human in task_actions(events):
            assert human.start is not None and human.end is not None
            watching = [s for s in steps if watches_human(plan.nodes[s.node])]
            # A sensing node that watches the human starts once the human is done.
            assert all(
                s.start is not None and s.start >= human.end for s in watching if s.seq > human.seq
            )
            # Where the plan's next node does not watch the human, the robot acts
            # while the human does (the request is followed by robot actions).
            following = next((s for s in steps if s.seq > human.seq), None)
            if following is not None and not watches_human(plan.nodes[following.node]):
                assert following.start is not None and following.end is not None
                assert following.start < human.end and human.start < following.end
                overlapped += 1
    assert overlapped > 0  # some seed takes a branch with a request the robot talks over


def test_the_simulated_human_answers_from_the_question_asked_to_its_answer(
    plan: Plan,
) -> None:
    """A question's answer is the human's activity (talk) while the robot waits."""
    for seed in SEEDS[:6]:
        events = simulated(plan, seed)
        questions = [e for e in events if e.kind == "communication" and e.outcome is not None]
        assert questions
        for question in questions:
            answers = [
                e for e in events
                if e.kind == HUMAN and e.node == question.node and e.end == question.end
            ]  # fmt: skip
            assert len(answers) == 1 and answers[0].source == "simulated"
            assert answers[0].start == question.wait_start
            assert question.start < question.wait_start < question.end  # type: ignore[operator]


def test_the_same_seed_gives_the_same_timed_session(plan: Plan) -> None:
    def timed(events: list[ExecutionEvent]) -> list[tuple[object, ...]]:
        return [(e.kind, e.node, e.outcome, e.start, e.end, e.text) for e in events]

    for seed in (3, 6):
        assert timed(simulated(plan, seed)) == timed(simulated(plan, seed))
    assert timed(simulated(plan, 3)) != timed(simulated(plan, 6))


def test_motions_keep_within_baxters_velocity_limits(plan: Plan) -> None:
    limits = joint_velocity_limits()
    for arm in ("left", "right"):
        for joint, velocity in BAXTER_VELOCITY_LIMITS.items():
            assert limits[f"{arm}_{joint}"] == velocity  # as the URDF gives them
    moves = [e for e in simulated(plan, 1) if e.kind == "actuation"]
    assert moves and all(e.motion is not None for e in moves)
    for event in moves:
        assert event.motion is not None and event.start is not None and event.end is not None
        seconds = event.end - event.start
        assert seconds == pytest.approx(motion_seconds(event.motion))
        path = event.motion.path
        for j, name in enumerate(event.motion.joints):
            travel = sum(abs(b[j] - a[j]) for a, b in zip(path, path[1:], strict=False))
            assert travel <= limits[name] * seconds + 1e-9


def test_a_sensing_action_waits_for_the_camera_and_a_line_lasts_its_audio(
    plan: Plan, tmp_path: Path
) -> None:
    robot = RobotVoice("en-us", "espeak", tmp_path)
    executor = Executor(plan, ExpectedSource(), narrator=robot, timeline=SimulatedTimeline(0))
    assert executor.run() == "goal"
    said = [e for e in executor.events if e.kind == "communication" and not e.outcome]
    assert said
    for event in said:
        assert event.evidence is not None and event.evidence.spoken is not None
        duration = event.evidence.spoken.duration_s
        assert duration is not None and duration > 0.3  # real espeak-ng audio
        assert event.end == pytest.approx(event.start + duration)  # type: ignore[operator]
    for event in (e for e in executor.events if e.kind == "sensing"):
        assert event.end == pytest.approx(event.start + CAMERA_SETTLE_S)  # type: ignore[operator]
    # Without audio, a line lasts its words at espeak-ng's rate.
    quiet = simulated(plan, 0)
    greeting = next(e for e in quiet if e.kind == "communication" and not e.outcome)
    words = len((plan.nodes[greeting.node].say or "").split())
    assert greeting.end == pytest.approx(greeting.start + words / SPEECH_WORDS_PER_S)  # type: ignore[operator]


def test_the_human_section_sets_the_humans_times() -> None:
    plan = paper_plan("paper-09")
    steady = Human(attach_s=20.0, attach_sigma=0.0, react_s=2.0, react_sigma=0.0)
    seen = 0
    for seed in range(4):
        events = simulated(plan, seed, steady)
        for human in (e for e in events if e.kind == HUMAN and "attaches" in (e.text or "")):
            assert human.end - human.start == pytest.approx(20.0)  # type: ignore[operator]
            seen += 1
    assert seen > 0


def test_the_wall_clock_times_real_runs_and_the_store_keeps_the_times(
    plan: Plan, tmp_path: Path
) -> None:
    wall = Executor(plan, RandomSource(5), timeline=WallTimeline())
    assert wall.run() == "goal"
    assert all(e.start is not None and e.end is not None for e in wall.events)
    assert all(e.start <= e.end == e.time for e in wall.events)  # type: ignore[operator]
    # A seeded choice is no person: nothing reports or observes a human's action.
    assert not [e for e in wall.events if e.kind == HUMAN]
    with SessionStore(tmp_path) as store:
        session = store.start(plan)
        timeline = SimulatedTimeline(5, origin=1_000.0)
        executor = Executor(plan, RandomSource(5), [store.recorder(session)], timeline=timeline)
        assert executor.run() == "goal"
        stored = store.events(session)
    assert [(e.kind, e.start, e.end) for e in stored] == [
        (e.kind, e.start, e.end) for e in executor.events
    ]
    assert any(e.kind == HUMAN for e in stored)


def test_an_older_store_gets_the_time_columns_and_its_sessions_are_untimed(
    tmp_path: Path,
) -> None:
    shutil.copy(OLD_STORE, tmp_path / "sessions.db")
    with SessionStore(tmp_path, read_only=True) as old:
        events = old.events(old.list_sessions()[0].id)
        assert events and all(e.start is None and e.end is None for e in events)
    with SessionStore(tmp_path) as store:
        columns = store.db["events"].columns_dict
        assert columns["started"] is float and columns["ended"] is float
        first = store.list_sessions()[0]
        assert all(e.start is None for e in store.events(first.id))
        plan = store.plan(first.plan_hash)
        session = store.start(plan)
        timeline = SimulatedTimeline(1, origin=2_000.0)
        Executor(plan, RandomSource(1), [store.recorder(session)], timeline=timeline).run()
        assert all(e.start is not None and e.start >= 2_000.0 for e in store.events(session))
