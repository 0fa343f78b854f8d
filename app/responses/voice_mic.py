"""`voice:mic`: a real microphone that listens all the time, as the simulated room does.

The microphone (`speech.microphone.MicrophoneStream`) is opened once, when the
voice is wired, and read by one `Ear` for the whole session: answers,
"stop" / "continue" at any time (`StopListener`), the dialogue's timeouts.
The ear closes it (the device is released) when the execution ends, however it
ends, or when the device goes away.

The robot's own voice is gated, not cancelled: a real room's echo path is not
known sample for sample, so every line is told to the ear with where it
sounds, and an utterance that starts within it (or `echo_tail_s` after) is
never an answer, nor a "continue".

- `local`: the lines play on this machine's output device (`DeviceSpeakers`),
  which says when each starts (the output latency included), and a "stop"
  cuts the line being said.
- `page`: the lines play in the dashboard's page; the ear's window opens when a
  line is sent and lasts `PAGE_LATENCY_S` longer than its audio (the page's
  delivery and decoding are not measured).
- `none`: the lines are only printed or shown; nothing is gated.

A device that goes away mid-session ends the voice with one line
(`on_lost`): the question being asked, and every later one, goes to the
fallback, and the execution goes on.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from app.execution.events import OutcomeSource
from app.execution.narration import Line, LineListener, RobotVoice
from app.responses.voice_answers import VoiceResponses
from app.sources.stop_listener import StopListener
from app.sources.voice import VoiceHooks
from app.sources.voice_answers import DEFAULT_TIMES, NO_HOOKS, DialogueVoice, VoiceAnswers
from speech.audio import RATE, read_wav, resample
from speech.dialogue import Commands, DialogueTimes, Ear
from speech.languages import Language
from speech.microphone import DeviceSpeakers, MicrophoneStream
from speech.recognition import Recognizer
from speech.synthesis import Engine

Speakers = Literal["local", "page", "none"]
PAGE_LATENCY_S = 0.5  # the page's delivery and decoding of a line, at most (assumed)


class MicSpeakers:
    """The robot's lines heard by the microphone's ear (see the module)."""

    def __init__(self, stream: MicrophoneStream, ear: Ear, where: Speakers) -> None:
        self.stream = stream
        self.ear = ear
        self.where = where
        self.device = DeviceSpeakers(stream.now_s, ear.robot_speaks) if where == "local" else None
        self.failed_told = False
        self.on_failed: Callable[[str], None] | None = None

    def __call__(self, line: Line) -> None:
        if line.utterance is None or line.utterance.format != "wav" or self.where == "none":
            return  # not spoken, or MP3 (the page plays it; its length alone is gated)
        recording = read_wav(line.utterance.path)
        if self.device is None:  # the page: from now, its latency ahead
            heard = resample(recording.samples, recording.rate, RATE)
            lead = np.zeros(int(PAGE_LATENCY_S * RATE), dtype=np.int16)
            self.ear.robot_speaks(np.concatenate([lead, heard]), self.stream.now_s())
            return
        self.device.play(recording.samples, recording.rate)
        if self.device.failed is not None and not self.failed_told:
            self.failed_told = True
            if self.on_failed is not None:
                self.on_failed(self.device.failed)

    def stop(self) -> None:
        """The robot falls silent now."""
        if self.device is not None:
            self.device.stop()
        self.ear.robot_stopped(self.stream.now_s())

    def close(self) -> None:
        """The session is over: the line being said ends, and no other is played."""
        if self.device is not None:
            self.device.close()


@dataclass(frozen=True)
class MicDialogue:
    """The live dialogue on the microphone: its stream, ear, speakers and stop listener."""

    language: Language
    recognizer: Recognizer
    times: DialogueTimes = DEFAULT_TIMES
    cache_dir: Path | None = None
    model_dir: Path | str | None = None
    speakers: Speakers = "local"

    def responses(
        self,
        fallback: OutcomeSource,
        lines: Sequence[LineListener] = (),
        hooks: VoiceHooks = NO_HOOKS,
        on_fallback: Callable[[str, str], None] | None = None,
        on_lost: Callable[[str], None] | None = None,
        on_unplayed: Callable[[str], None] | None = None,
        engine: Engine = "auto",
    ) -> VoiceResponses:
        """Opens the microphone (`NoAudioDevice`, one line, when there is none)."""
        commands = Commands(self.language, self.model_dir)  # the model before the device
        stream = MicrophoneStream()
        try:
            return self._wired(stream, commands, fallback, lines, hooks, on_fallback,
                               on_lost, on_unplayed, engine)  # fmt: skip
        except BaseException:
            stream.close()  # released on this path too: nothing else holds it yet
            raise

    def _wired(
        self,
        stream: MicrophoneStream,
        commands: Commands,
        fallback: OutcomeSource,
        lines: Sequence[LineListener],
        hooks: VoiceHooks,
        on_fallback: Callable[[str, str], None] | None,
        on_lost: Callable[[str], None] | None,
        on_unplayed: Callable[[str], None] | None,
        engine: Engine,
    ) -> VoiceResponses:
        ear = Ear(stream, self.times, commands, cancel_echo=False)
        speakers = MicSpeakers(stream, ear, self.speakers)
        speakers.on_failed = on_unplayed
        # The speakers last, so a line is printed (or shown) before it is played.
        # espeak-ng when played here: the device plays WAV (gTTS gives MP3).
        voice_engine: Engine = "espeak" if self.speakers == "local" else engine
        robot = RobotVoice(self.language, voice_engine, self.cache_dir, [*lines, speakers])
        stops = StopListener(ear, robot, on_stop=speakers.stop)
        ear.on_command = stops
        voice = DialogueVoice(self.language, stream, ear, self.recognizer, robot, hooks)
        voice.wall_of = stream.wall_s
        answers = VoiceAnswers(voice, fallback, on_fallback, stops)
        answers.on_detach.append(speakers.close)

        def lost(why: str) -> None:  # the ear's thread: the device went away
            answers.voice_ended(why)
            if on_lost is not None:
                on_lost(why)

        ear.on_lost = lost
        ear.start()
        return VoiceResponses(answers, voice, robot, None, None, ear, stops)
