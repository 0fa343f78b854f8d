"""The human's speech as the human's activity, on the clock of the robot's steps.

A `voice:sim` run is simulated: every question lasts as its dialogue's audio,
and each answer the human spoke is a `human` event of source `voice` inside the
question's wait, as long as the speech in the answer's audio (measured here
again from a fresh synthesis of the same voice, speed, pitch and words). A run
on the wall clock hears the simulated human through a microphone in the
simulated room (the microphone's own cut and timing), and finds the human's
speech where the room played it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from app.cli.main import main
from app.execution.events import HUMAN, ExecutionEvent, is_step
from app.execution.narration import RobotVoice
from app.execution.timing import WallTimeline
from app.execution.walker import Executor
from app.responses.voice_room import LiveDialogue
from app.sessions.store import SessionStore
from app.sim.speaker import SimulatedSpeaker
from app.sources.outcomes import RandomSource
from app.sources.voice import VoiceHooks, VoiceSource
from app.sources.voice_answers import VoiceAnswers
from planner.plan.model import Plan, PlanNode
from speech.audio import RATE
from speech.recognition import Recognizer
from speech.sources import RoomMicrophone, SimulatedRoom, SimulatedVoice, Span
from speech.synthesis import espeak_samples
from tests.plan_fixtures import KOREAN_DEFAULT, ROOT, korean_plan, tandem

ENGLISH_DEFAULT = ROOT / "static" / "scenarios" / "default.toml"


def _speech_seconds(origin: str) -> float:
    """How long the words of a simulated answer last: its audio synthesised again, from
    the first to the last sample above 2 % of its peak."""
    _, voice, speed, pitch, _, text = origin.split(":", 5)
    samples = np.abs(espeak_samples(text, voice, int(speed[1:]), int(pitch[1:])).astype(float))
    loud = np.flatnonzero(samples > 0.02 * samples.max())
    return float(loud[-1] - loud[0]) / RATE


def _check_consistent(events: Sequence[ExecutionEvent], ended: float | None) -> None:
    """One clock: every event timed, start <= end, motions as long as motions are, the
    steps in order, the session ending with its last event."""
    assert events
    for event in events:
        assert event.start is not None and event.end is not None, event
        assert event.start <= event.end, event
        if event.wait_start is not None:
            assert event.start <= event.wait_start <= event.end, event
        if event.kind == "actuation":
            assert event.end - event.start >= 0.3, event
    steps = [(e.start or 0.0, e.end or 0.0) for e in events if is_step(e)]
    assert all(a[1] <= b[0] + 1e-6 for a, b in zip(steps, steps[1:], strict=False))
    assert ended is not None and abs(ended - max(e.end or 0.0 for e in events)) < 1e-3


def _check_speech(plan: Plan, events: Sequence[ExecutionEvent]) -> int:
    """Each question's speech events lie within its wait and last as the answers' speech;
    how many were checked."""
    checked = 0
    for question in [
        e for e in events if e.kind == "communication" and plan.nodes[e.node].outcomes
    ]:
        hearing = question.evidence.voice if question.evidence is not None else None
        if hearing is None:
            continue
        said = [
            e for e in events if e.kind == HUMAN and e.source == "voice" and e.node == question.node
        ]
        spoken = [a for a in hearing.attempts if a.reason != "silence"]
        assert len(said) == len(spoken), (question, said)
        assert question.wait_start is not None and question.end is not None
        for event, attempt in zip(said, spoken, strict=True):
            assert event.start is not None and event.end is not None
            assert question.wait_start <= event.start < event.end <= question.end, (question, event)
            assert attempt.audio is not None
            assert abs((event.end - event.start) - _speech_seconds(attempt.audio)) <= 0.2, attempt
            checked += 1
    return checked


def test_voice_sim_speech_lies_within_each_question_and_lasts_as_its_audio(tmp_path: Path) -> None:
    data = tmp_path / "data"
    for seed in range(4):
        code = main([
            "execute", str(KOREAN_DEFAULT), "--responses", "voice:sim", "--seed", str(seed),
            "--data-dir", str(data),
        ])  # fmt: skip
        assert code == 0
    plan = korean_plan()
    checked = 0
    with SessionStore(data) as store:
        for session in store.list_sessions():
            assert session.clock == "simulated"
            events = store.events(session.id)
            _check_consistent(events, session.ended)
            checked += _check_speech(plan, events)
    assert checked >= 4


def test_a_cli_voice_sim_session_has_consistent_times(tmp_path: Path) -> None:
    env = {**os.environ, "TANDEM_DATA_DIR": str(tmp_path)}
    env.pop("TANDEM_VOSK_MODEL", None)  # English by pocketsphinx, as a new user has it
    done = tandem(
        "execute", str(ENGLISH_DEFAULT), "--responses", "voice:sim", "--seed", "32", env=env
    )
    assert done.returncode == 0, done.stderr
    session_id = int(done.stdout.split()[1])
    with SessionStore(tmp_path) as store:
        record = store.get(session_id)
        events = store.events(session_id)
        plan = store.plan(record.plan_hash)
    assert record.clock == "simulated"
    _check_consistent(events, record.ended)
    speech = [e for e in events if e.kind == HUMAN and e.source == "voice"]
    # Seed 32: the first "no" is refused for low confidence, the second taken, then a yes.
    assert len(speech) >= 2 and any("refused" in (e.text or "") for e in speech), speech
    assert _check_speech(plan, events) == len(speech)


@pytest.fixture(scope="module")
def korean() -> Recognizer:
    return Recognizer("ko")


def test_a_microphone_on_the_wall_clock_keeps_the_speech_where_it_was_said(
    korean: Recognizer, tmp_path: Path
) -> None:
    """The default Korean plan on the wall clock (motions drawn at once by a player), the
    simulated human answering into a room that a microphone listens to."""
    plan = korean_plan()
    room = SimulatedRoom(seed=2)
    speaker = SimulatedSpeaker(SimulatedVoice("ko", seed=2, room=room), seed=2)
    played: dict[str, list[Span]] = {}

    def answer(node_id: str, node: PlanNode, options: Sequence[str]) -> None:
        speaker(node_id, node, options)
        assert speaker.voice.spoken_at is not None
        played.setdefault(node_id, []).append(speaker.voice.spoken_at)

    robot = RobotVoice("ko", "espeak", tmp_path)
    voice = VoiceSource("ko", RoomMicrophone(room), korean, robot,
                        hooks=VoiceHooks(on_question=answer))  # fmt: skip
    executor = Executor(plan, VoiceAnswers(voice, RandomSource(2)), narrator=robot,
                        timeline=WallTimeline(), player=lambda node_id, motion: None)  # fmt: skip
    assert executor.run() == "goal"
    events = executor.events
    questions = [e for e in events if e.kind == "communication" and e.node in played]
    assert questions
    worst = 0.0
    for question in questions:
        said = [
            e for e in events if e.kind == HUMAN and e.source == "voice" and e.node == question.node
        ]
        spans = played[question.node]
        assert len(said) == len(spans)
        for event, span in zip(said, spans, strict=True):
            assert event.start is not None and event.end is not None
            # Where the room played the words, on the wall clock (30 ms blocks, 20 ms frames).
            off = (event.start - room.wall_s(span.speech_start_s),
                   event.end - room.wall_s(span.speech_end_s))  # fmt: skip
            assert max(map(abs, off)) <= 0.1, (event, span)
            worst = max(worst, *map(abs, off))
            assert question.wait_start is not None and question.end is not None
            assert question.wait_start <= event.start < event.end <= question.end
    print(f"\nspeech on the wall clock: {len(questions)} questions, worst offset {worst:.3f} s")


def test_the_live_ear_keeps_the_humans_answers_on_the_wall_clock(
    korean: Recognizer, tmp_path: Path
) -> None:
    """The live dialogue (the simulated room, in real time): each answer the ear took is
    the human's speech where the room played it; the robot's own voice is none."""
    plan = korean_plan()
    voice = LiveDialogue(korean.language, korean, cache_dir=tmp_path).responses(
        RandomSource(4), seed=4
    )
    assert voice.room is not None and voice.speaker is not None
    room, human = voice.room, voice.speaker.voice
    executor = Executor(plan, voice.source, narrator=voice.robot, timeline=WallTimeline(),
                        player=lambda node_id, motion: None)  # fmt: skip
    executor.start()
    # Bounded: a run that never ends (paused by a "stop" heard where none was said, an
    # ear that stopped hearing) fails here with what the ear heard, not after 600 s.
    result = executor.wait(240)
    if result is None:
        executor.abort()
    assert voice.ear is not None
    heard = [(round(h.start_s, 2), h.words, h.meaning or h.command or h.reason)
             for h in voice.ear.heard]  # fmt: skip
    assert result == "goal", (executor.paused, voice.ear.lost, heard)
    said = [e for e in executor.events if e.kind == HUMAN and e.source == "voice"]
    # Everything the human said into the room (the answers, and a "continue" after an
    # answer heard as a stop: `HumanInTheRoom`) but what began over the robot's voice
    # (its "going on" and a question asked again may overlap an answer): that is
    # refused as the robot's own voice, never the human's speech.
    own = [h.start_s for h in voice.ear.heard if h.reason == "own voice"]
    played = [s for s in human.said if not any(s.start_s <= at <= s.end_s for at in own)]
    assert played and len(said) == len(played), ([e.text for e in said], heard)
    for event, span in zip(said, played, strict=True):
        assert event.start is not None and event.end is not None
        assert (event.text or "").startswith(("the human says", "the human speaks"))
        assert abs(event.start - room.wall_s(span.speech_start_s)) <= 0.1, (event, span)
        assert abs(event.end - room.wall_s(span.speech_end_s)) <= 0.1, (event, span)
