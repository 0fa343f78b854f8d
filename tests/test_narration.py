"""The robot's voice in an execution: every communication spoken as it is reached."""

from __future__ import annotations

import wave
from pathlib import Path

from app.execution.narration import Line, RobotVoice, plan_language
from app.execution.walker import Executor
from app.sources.outcomes import ExpectedSource, RandomSource
from tests.plan_fixtures import default_plan, korean_plan


def test_every_communication_is_spoken_when_reached_and_kept_with_its_event(
    tmp_path: Path,
) -> None:
    plan = default_plan()
    assert plan_language(plan) == "en-us"
    heard: list[Line] = []
    robot = RobotVoice("en-us", "espeak", tmp_path, [heard.append])
    executor = Executor(plan, RandomSource(2), narrator=robot)
    assert executor.run() == "goal"
    spoken = [e for e in executor.events if e.kind == "communication"]
    assert spoken and len(heard) == len(spoken)
    for event, line in zip(spoken, heard, strict=True):
        assert event.evidence is not None
        assert event.evidence.spoken.said == line.text == plan.nodes[event.node].say
        assert event.evidence.spoken.engine == "espeak" == line.engine
        assert line.utterance is not None
        with wave.open(str(line.utterance.path)) as audio:
            assert audio.getnframes() > 0.3 * audio.getframerate()
    # Nothing else is spoken: actions and sensing carry no speech.
    assert all(e.evidence is None for e in executor.events if e.kind != "communication")


def test_questions_can_be_left_to_the_voice_source(tmp_path: Path) -> None:
    plan = korean_plan()
    robot = RobotVoice(plan_language(plan), "espeak", tmp_path, questions=False)
    executor = Executor(plan, ExpectedSource(), narrator=robot)
    assert executor.run() == "goal"
    asked = {e.node for e in executor.events if e.kind == "communication" and e.outcome}
    told = {line.node_id for line in robot.lines}
    assert asked and not asked & told
    assert all(any("\uac00" <= c <= "\ud7a3" for c in line.text) for line in robot.lines)


def test_a_voice_that_cannot_speak_does_not_stop_the_session(tmp_path: Path) -> None:
    """gTTS alone: offline, every line fails and is kept with its error; online,
    every line is gTTS's. Either way the session goes on and each line is kept."""
    plan = default_plan()
    robot = RobotVoice("en-us", "gtts", tmp_path)
    executor = Executor(plan, ExpectedSource(), narrator=robot)
    assert executor.run() == "goal"
    said = [e for e in executor.events if e.kind == "communication"]
    assert said and len(robot.lines) == len(said)
    for event, line in zip(said, robot.lines, strict=True):
        assert event.evidence is not None and event.evidence.spoken.said == line.text
        assert event.evidence.spoken.engine == line.engine
        if line.utterance is None:  # offline: gTTS never answers
            assert line.engine == "none" and line.error
            assert event.evidence.spoken.speech_error == line.error
        else:  # online: gTTS spoke, with no fallback and no error
            assert line.engine == "gtts" and line.error is None
            assert line.utterance.path.stat().st_size > 0
    # A failed request writes nothing: no empty file is left for the cache to serve.
    assert not [p for p in tmp_path.rglob("*") if p.is_file() and p.stat().st_size == 0]
