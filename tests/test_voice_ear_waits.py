"""An answer wait always ends: the live ear's timeouts when its audio stops coming.

A `tests/test_voice_clock.py` run once hung for 600 s in `Ear.answer`: its
no-speech time runs on the stream's clock, which stands still when no block
comes (an ear whose thread failed, a device that hangs), so the wait never
ended. Here the stream stalls, or the ear's thread fails on what it heard, and
the wait ends all the same; and a sound the simulated room is told to play at a
time its stream has already passed is heard whole, later, not with its start
cut off (the robot's voice, so cut, left a residue after the echo canceller that
the ear heard as speech).
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from speech.audio import BLOCK, RATE, Samples
from speech.dialogue import Answer, DialogueTimes, Ear, Hearing
from speech.recognition import Recognizer
from speech.sources import SimulatedRoom, SimulatedVoice


@pytest.fixture(scope="module")
def english() -> Recognizer:
    return Recognizer("en-us")


class StallingStream:
    """A faint noise for `blocks` blocks in real time, then nothing ever again (a device
    that hangs without an error)."""

    def __init__(self, blocks: int) -> None:
        self.blocks = blocks
        self._read = 0
        self._noise = np.random.default_rng(0)
        self.stalled = threading.Event()

    @property
    def position_s(self) -> float:
        return self._read / RATE

    def read(self) -> Samples:
        if self._read >= self.blocks * BLOCK:
            self.stalled.set()
            threading.Event().wait()  # for ever
        time.sleep(BLOCK / RATE)
        self._read += BLOCK
        return self._noise.normal(0, 30, BLOCK).astype(np.int16)


def answered_within(ear: Ear, recognizer: Recognizer, seconds: float) -> Answer | None:
    """`ear.answer` in a thread: its answer, or None if it still waits after `seconds`."""
    got: list[Answer] = []
    waiting = threading.Thread(target=lambda: got.append(ear.answer(recognizer)), daemon=True)
    waiting.start()
    waiting.join(seconds)
    return got[0] if got else None


def test_an_answer_wait_ends_when_the_stream_stops_giving_audio(english: Recognizer) -> None:
    stream = StallingStream(blocks=20)
    ear = Ear(stream, DialogueTimes(no_speech_s=1.0)).start()
    assert stream.stalled.wait(5)
    answer = answered_within(ear, english, 5.0)
    assert answer is not None, "the answer wait never ended"
    assert answer.hearing is None and answer.reason == "no audio"
    ear.close(wait_s=0.1)


def test_an_answer_wait_ends_when_the_ears_thread_fails(english: Recognizer) -> None:
    room = SimulatedRoom(seed=1)
    ear = Ear(room, DialogueTimes(no_speech_s=30.0))
    lost: list[str] = []
    ear.on_lost = lost.append

    def failing(hearing: Hearing) -> None:
        raise RuntimeError("a listener failed on what was heard")

    ear.on_heard = failing
    ear.start()
    SimulatedVoice("en-us", seed=1, room=room).say_at("hello there", room.now_s() + 0.5)
    answer = answered_within(ear, english, 15.0)
    assert answer is not None, "the answer wait never ended"
    assert answer.hearing is None
    assert lost == ["a listener failed on what was heard"] and ear.lost == lost[0]


def test_a_sound_played_at_a_time_already_past_is_heard_whole() -> None:
    room = SimulatedRoom(seed=2, noise_db=-90.0)
    while room.position_s < 0.6:
        room.read()
    tone = (8000 * np.sin(np.arange(RATE // 2) * 2 * np.pi * 440 / RATE)).astype(np.int16)
    span = room.play(tone, at_s=0.3)  # the stream is at 0.6 s already
    assert span.start_s >= 0.6 - 1e-9
    heard = []
    while room.position_s < span.end_s + 0.1:
        heard.append(room.read())
    energy = float(np.sum(np.concatenate(heard).astype(np.float64) ** 2))
    assert energy >= 0.99 * float(np.sum(tone.astype(np.float64) ** 2))
