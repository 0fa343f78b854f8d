"""`voice:mic` through a real audio device: the virtual microphone of `tests.audio_device`.

The human's words are espeak-ng speech played into the device in real time;
the robot's lines play on the default output, the same device, so the
microphone hears the robot as it would in a room. PortAudio records it, the
always-on ear hears it: answers taken, the robot's own voice never one,
"stop" mid-motion pauses the arm, and a device that goes away ends the voice
with one line while the execution goes on with the fallback.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pytest

from app.execution.walker import Executor
from app.responses.voice import (
    SpeechModels,
    VoiceListeners,
    VoiceResponses,
    voice_responses,
)
from app.sources.outcomes import RandomSource
from planner.plan.model import PlanNode
from speech.audio import Samples
from speech.dialogue import Hearing
from speech.microphone import MicrophoneStream
from speech.recognition import Recognizer
from speech.synthesis import espeak_samples
from speech.voice_activity import activity
from tests.audio_device import SoundServer, microphone, sound_server  # noqa: F401
from tests.plan_fixtures import default_plan

ANSWER_WORDS = {"yes": "yes", "no": "no"}


@pytest.fixture(scope="module")
def english() -> Recognizer:
    return Recognizer("en-us")


def spoken(text: str) -> Samples:
    """`text` in espeak-ng's default English voice, its silent ends trimmed."""
    samples = espeak_samples(text, "en-us")
    loud = np.flatnonzero(activity(samples, 16_000).active)
    frame = len(samples) // max(1, len(activity(samples, 16_000).active))
    return samples[max(0, loud[0] * frame - 800) : (loud[-1] + 1) * frame + 800]


def until(condition: Callable[[], bool], within_s: float) -> bool:
    deadline = time.monotonic() + within_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def mic_voice(recognizer: Recognizer, cache: Path, lost: list[str]) -> VoiceResponses:
    return voice_responses(
        "mic", "en-us", RandomSource(1),
        speech=SpeechModels(recognizer, cache_dir=cache),
        told=VoiceListeners(on_lost=lost.append),
    )  # fmt: skip


def answering(device: SoundServer, voice: VoiceResponses, answers: list[str]) -> None:
    """The human answers each question aloud, 0.3 s after the robot has asked."""
    def answer(node_id: str, node: PlanNode, options: Sequence[str]) -> None:
        word = answers[len(asked) % len(answers)]
        asked.append(word)
        threading.Timer(0.3, lambda: device.play(spoken(word), "answer")).start()

    asked: list[str] = []
    voice.voice.on_question = answer


def _heard(voice: VoiceResponses) -> list[Hearing]:
    assert voice.ear is not None
    return voice.ear.heard


def test_answers_are_heard_through_the_device_and_the_robots_voice_is_not_one(
    microphone: SoundServer, english: Recognizer, tmp_path: Path  # noqa: F811
) -> None:
    lost: list[str] = []
    voice = mic_voice(english, tmp_path, lost)
    assert microphone.recording_streams(), "the microphone is opened once, when wired"
    answering(microphone, voice, ["yes", "no"])
    executor = Executor(default_plan(), voice.source, narrator=voice.robot,
                        player=lambda node_id, motion: None)  # fmt: skip
    executor.start()
    result = executor.wait(240)
    if result is None:
        executor.abort()
    assert result == "goal", _heard(voice)
    questions = [e for e in executor.events if e.kind == "communication" and e.outcome]
    assert questions and all(e.source == "voice" for e in questions), _heard(voice)
    # The robot's lines reached the microphone, and none was taken as an answer.
    own = [h for h in _heard(voice) if h.reason == "own voice"]
    assert own and all(h.meaning is None and h.command is None for h in own), _heard(voice)
    assert not lost
    assert not microphone.recording_streams(), "the device is released when the run ends"


def test_stop_said_mid_motion_pauses_the_arm_and_continue_resumes(
    microphone: SoundServer, english: Recognizer, tmp_path: Path  # noqa: F811
) -> None:
    lost: list[str] = []
    voice = mic_voice(english, tmp_path, lost)
    answering(microphone, voice, ["yes"])
    assert voice.stops is not None and voice.ear is not None
    stream = voice.ear.stream
    assert isinstance(stream, MicrophoneStream)
    # A waypoint every 0.1 s: the first motion lasts about 3 s.
    executor = Executor(default_plan(), voice.source, narrator=voice.robot, waypoint_s=0.1)
    paused_at: list[float] = []

    def watch() -> None:
        if until(lambda: executor.paused, 120):
            paused_at.append(time.time())

    watching = threading.Thread(target=watch, daemon=True)
    executor.start()
    # Mid-motion, and past the robot's window: its voice is gated, not cancelled, so a
    # command said over it (or within the echo tail after it) is not taken.
    assert until(lambda: executor.waypoint is not None and executor.waypoint.index >= 3
                 and voice.ear is not None and voice.ear.robot_until_s < stream.position_s,
                 60)  # fmt: skip
    assert executor.waypoint is not None and executor.waypoint.index < 15, "motion nearly over"
    watching.start()
    microphone.play(spoken("stop"), "stop")
    assert until(lambda: executor.paused, 10), _heard(voice)
    at_pause = executor.waypoint
    assert at_pause is not None, "the pause came after the motion"
    time.sleep(0.6)  # six waypoints' time: the arm must not move on
    halted = executor.waypoint
    assert halted is not None and halted.node == at_pause.node
    assert at_pause.index <= halted.index <= at_pause.index + 1 < halted.count
    (stop,) = [h for h in _heard(voice) if h.command == "stop"]
    # From the end of the word, as the microphone recorded it, to the arm's pause.
    word_end = stream.wall_s(stop.spoken_until_s)
    watching.join(5)
    latency = paused_at[0] - word_end
    print(f"\nstop through the device: paused {latency:.3f} s after the end of the word")
    assert latency <= 0.5, (latency, stop)
    # The robot says it stopped; once it has, "continue" resumes.
    assert until(lambda: voice.ear is not None and voice.ear.robot_until_s < stream.position_s, 10)
    for word in ("continue", "resume", "continue"):
        microphone.play(spoken(word), "continue")
        if until(lambda: not executor.paused, 4):
            break
    assert not executor.paused, _heard(voice)
    # The arm goes on from where it stopped (the rest of the plan is the first test's).
    assert until(lambda: executor.waypoint != halted, 5), "the arm did not move on"
    executor.abort()
    executor.wait(30)
    turns = [e.kind for e in executor.events if e.kind in ("paused", "resumed")]
    assert turns == ["paused", "resumed"] and not lost
    assert not microphone.recording_streams(), "the device is released when the run ends"
