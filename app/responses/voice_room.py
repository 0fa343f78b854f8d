"""The live simulated dialogue: one `SimulatedRoom`, its ear, the robot's speakers in it.

`voice:sim` with `live=True` (the dashboard's "simulated room"): the robot's
sentences and the simulated human's words share one simulated microphone in
real time (see `app.responses.voice`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from app.execution.events import OutcomeSource
from app.execution.narration import Line, LineListener, RobotVoice
from app.responses.voice_answers import VoiceResponses, human_script
from app.sim.speaker import SimulatedSpeaker
from app.sources.stop_listener import StopListener
from app.sources.voice import VoiceHooks
from app.sources.voice_answers import DEFAULT_TIMES, NO_HOOKS, DialogueVoice, VoiceAnswers
from speech.audio import RATE, read_wav, resample
from speech.dialogue import BLOCK_S, COMMAND_WORDS, Command, Commands, DialogueTimes, Ear, Hearing
from speech.languages import Language
from speech.recognition import Recognizer
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


@dataclass(frozen=True)
class LiveDialogue:
    """The live simulated dialogue: one room, its ear, the robot's speakers in it.

    `cancel_echo` False leaves the robot's voice in what the ear hears (only the
    self-hearing window keeps it from being an answer).
    """

    language: Language
    recognizer: Recognizer
    times: DialogueTimes = DEFAULT_TIMES
    cache_dir: Path | None = None
    model_dir: Path | str | None = None
    cancel_echo: bool = True

    def responses(
        self,
        fallback: OutcomeSource,
        seed: int | None,
        human: str = "random",
        lines: Sequence[LineListener] = (),
        hooks: VoiceHooks = NO_HOOKS,
        on_fallback: Callable[[str, str], None] | None = None,
    ) -> VoiceResponses:
        room = SimulatedRoom(seed)
        speaker = SimulatedSpeaker(SimulatedVoice(self.language, seed=seed, room=room),
                                   seed=seed, script=human_script(human))  # fmt: skip
        commands = Commands(self.language, self.model_dir)
        ear = Ear(room, self.times, commands, cancel_echo=self.cancel_echo)
        speakers = RoomSpeakers(room, ear)
        # espeak-ng: the room plays WAV; the speakers last, so a line is printed first.
        robot = RobotVoice(self.language, "espeak", self.cache_dir, [*lines, speakers])
        stops = StopListener(ear, robot, on_stop=speakers.stop)
        ear.on_command = HumanInTheRoom(stops, speaker.voice, room)
        hooks = replace(hooks, on_question=speaker, truth=speaker.truth)
        voice = DialogueVoice(self.language, speaker.voice, ear, self.recognizer, robot, hooks)
        voice.wall_of = room.wall_s
        ear.start()
        answers = VoiceAnswers(voice, fallback, on_fallback, stops)
        return VoiceResponses(answers, voice, robot, speaker, room, ear, stops)
