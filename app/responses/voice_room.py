"""The live simulated dialogue: one `SimulatedRoom`, its ear, the robot's speakers in it.

`voice:sim` with `live=True` (the dashboard's "simulated room"): the robot's
sentences and the simulated human's words share one simulated microphone in
real time (see `app.responses.voice`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from app.execution.events import OutcomeSource
from app.execution.narration import LineListener, RobotVoice
from app.responses.voice_answers import VoiceResponses, human_script
from app.sim.room import HumanInTheRoom, RoomSpeakers
from app.sim.speaker import SimulatedSpeaker
from app.sources.stop_listener import StopListener
from app.sources.voice import VoiceHooks
from app.sources.voice_answers import DEFAULT_TIMES, NO_HOOKS, DialogueVoice, VoiceAnswers
from speech.dialogue import Commands, DialogueTimes, Ear
from speech.languages import Language
from speech.recognition import Recognizer
from speech.sources import SimulatedRoom, SimulatedVoice


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
