"""The simulated room's side of a live dialogue: the robot's speakers in the room
and the simulated human who tells the robot to go on after a stop it did not mean.

`app.responses.voice_room` wires them with the room's ear (`LiveDialogue`).
"""

from __future__ import annotations

import threading
import time

from app.execution.narration import Line
from app.sources.stop_listener import StopListener
from speech.audio import RATE, read_wav, resample
from speech.dialogue import BLOCK_S, COMMAND_WORDS, Command, Ear, Hearing
from speech.sources import SimulatedRoom, SimulatedVoice


class RoomSpeakers:
    """The robot's speakers in the simulated room: each line is played into the room
    (as its microphone hears it) and the ear is told; the robot waits until it has
    said the line, or until it is stopped (`stop`)."""

    def __init__(self, room: SimulatedRoom, ear: Ear) -> None:
        self.room = room
        self.ear = ear

    def __call__(self, line: Line) -> None:
        if line.utterance is None or line.utterance.format != "wav":
            return  # not spoken, or MP3 (a simulated room plays espeak-ng's WAV)
        recording = read_wav(line.utterance.path)
        samples = resample(recording.samples, recording.rate, RATE)
        span = self.room.play_robot(samples, told=self.ear.robot_speaks)
        while self.room.position_s < min(span.end_s, self.room.robot_until_s):
            time.sleep(BLOCK_S)

    def stop(self) -> None:
        """The robot falls silent now."""
        self.room.cut_robot()
        self.ear.robot_stopped(self.room.now_s())


class HumanInTheRoom:
    """The simulated human's side of "stop": when an answer of theirs was heard as a
    stop (espeak-ng's 맞아 in one voice sounds like 멈춰 to the model), they tell the
    robot to go on once it has said that it stopped, and say it again while it does
    not, as a person would; a stop they said themselves (the dashboard's **Human
    says stop**) stands."""

    TRIES = 3

    def __init__(self, stops: StopListener, voice: SimulatedVoice, room: SimulatedRoom) -> None:
        self.stops = stops
        self.voice = voice
        self.room = room
        self._resumed = threading.Event()

    def __call__(self, command: Command, hearing: Hearing) -> None:
        self.stops(command, hearing)
        if command == "continue":
            self._resumed.set()
            return
        answer = self.voice.answered_at
        if answer is None or self.stops.controls is None:
            return
        if answer.start_s <= hearing.start_s + BLOCK_S and hearing.start_s <= answer.end_s:
            self._resumed.clear()
            threading.Thread(target=self._go_on, name="human-goes-on", daemon=True).start()

    def _go_on(self) -> None:
        words = COMMAND_WORDS[self.voice.language.code][1]
        for attempt in range(self.TRIES):
            self.stops.said(30.0)  # "I stopped" first: a "continue" over it is not taken
            at = max(self.room.now_s(), self.room.robot_until_s) + 0.4
            self.voice.say_at(words[attempt % len(words)], at)
            said = self.voice.spoken_at
            assert said is not None
            # Heard within a second of its end, or said again.
            if self._resumed.wait(said.end_s - self.room.now_s() + 1.0):
                return
