"""`--responses voice:SOURCE`: the voice answers the questions of an execution.

SOURCE is `sim` (a seeded simulated human chooses each answer, randomly or
from a script, and says it through espeak-ng into the real recogniser), `mic`
(the microphone, listening all the time: `app.responses.voice_mic`) or a
folder of WAV files (one answer a file, in name order). The robot speaks
every communication node as it is reached (`RobotVoice` as the executor's
narrator; the questions are spoken by the voice source before each listen).
Nodes the voice does not answer (sensing, or a question refused twice) go to
the fallback; every question's event carries the voice's evidence either way,
so a session says which answered.

With `live=True` (`sim`; `app.responses.voice_room`) the dialogue listens all
the time, as it would in a room (`speech.dialogue`), as `mic` always does: the
robot's sentences and the simulated human's words share one simulated
microphone in real time, the robot never takes its
own voice for an answer, the scenario's `DialogueTimes` bound the waits, and
"stop" / "continue" pause and resume the execution (`StopListener`). The
dialogue's turns (asked again, fell back, too long, own voice, paused,
resumed) are kept as events of the execution that `attach`es the source.

The human's speech is the human's activity: each utterance taken as the human's
(an answer, refused or not, a command; not the robot's own voice, not silence)
is kept as a `human` event of source `voice`, from its voice-activity onset to
the end of its speech, on the execution's clock (`app.sources.voice_clock`:
the wall clock, or a `DialogueTimeline`; on another simulated clock the voice
keeps no times). The robot asks each question as the narrator reaches it, and
again before a second try.

No speech model for the language is `NoSpeechModel` (one line); no
microphone is `NoAudioDevice`; a missing folder `FileNotFoundError`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from app.execution.events import OutcomeSource
from app.execution.narration import LineListener, RobotVoice
from app.responses.voice_answers import VoiceResponses, human_script
from app.responses.voice_mic import MicDialogue
from app.responses.voice_room import LiveDialogue
from app.sim.speaker import SimulatedSpeaker
from app.sources.voice import AttemptListener, ListeningListener, VoiceHooks, VoiceSource
from app.sources.voice_answers import DEFAULT_TIMES, VoiceAnswers
from planner.scenario.sections import Human
from speech.dialogue import DialogueTimes
from speech.languages import language
from speech.recognition import Recognizer
from speech.sources import AudioSource, SimulatedVoice, WavFolderSource
from speech.synthesis import Engine

# Re-exported: where the voice's pieces were found before they had modules of their own.
__all__ = [
    "DEFAULT_TIMES", "LiveDialogue", "MicDialogue", "MicOptions", "VoiceAnswers",
    "VoiceResponses", "dialogue_times", "human_script", "voice_responses",
]


@dataclass(frozen=True)
class MicOptions:
    """`voice:mic`: where the robot's lines play (`local`, the `page`, `none`), and who
    is told (one line) that the microphone went away or a line could not be played."""

    speakers: Literal["local", "page", "none"] = "local"
    on_lost: Callable[[str], None] | None = None
    on_unplayed: Callable[[str], None] | None = None


def dialogue_times(human: Human) -> DialogueTimes:
    """The dialogue's times from a scenario's `[human]` section."""
    return DialogueTimes(human.no_speech_s, human.end_of_speech_s, human.max_utterance_s)


def voice_responses(
    spec: str,
    language_code: str,
    fallback: OutcomeSource,
    *,
    seed: int | None = None,
    human: str = "random",
    model_dir: Path | str | None = None,
    engine: Engine = "auto",
    cache_dir: Path | None = None,
    on_line: LineListener | None = None,
    on_attempt: AttemptListener | None = None,
    on_listening: ListeningListener | None = None,
    on_fallback: Callable[[str, str], None] | None = None,
    recognizer: Recognizer | None = None,
    live: bool = False,
    times: DialogueTimes = DEFAULT_TIMES,
    mic: MicOptions = MicOptions(),
) -> VoiceResponses:
    """The voice source for `voice:SOURCE` (see the module docstring for the errors);
    `live` (with `sim`) listens all the time, within the dialogue's `times`; `mic`
    always does (`app.responses.voice_mic`)."""
    lang = language(language_code)
    # The model first: without one nothing else is worth opening.
    hearing = recognizer if recognizer is not None else Recognizer(lang, model_dir)
    lines = [on_line] if on_line else []
    if spec == "mic":
        hooks = VoiceHooks(on_attempt=on_attempt, on_listening=on_listening)
        dialogue = MicDialogue(lang, hearing, times, cache_dir, model_dir, mic.speakers)
        return dialogue.responses(fallback, lines, hooks, on_fallback, mic.on_lost,
                                  mic.on_unplayed, engine)  # fmt: skip
    if live:
        if spec != "sim":
            raise ValueError("a live simulated dialogue is voice:sim (voice:mic is always live)")
        hooks = VoiceHooks(on_attempt=on_attempt, on_listening=on_listening)
        wiring = LiveDialogue(lang, hearing, times, cache_dir, model_dir)
        return wiring.responses(fallback, seed, human, lines, hooks, on_fallback)
    speaker: SimulatedSpeaker | None = None
    audio: AudioSource
    if spec == "sim":
        speaker = SimulatedSpeaker(SimulatedVoice(lang, seed=seed), seed=seed,
                                   script=human_script(human))  # fmt: skip
        audio = speaker.voice
    else:
        audio = WavFolderSource(spec)
    robot = RobotVoice(lang, engine, cache_dir, lines)
    hooks = VoiceHooks(
        on_question=speaker,
        truth=speaker.truth if speaker is not None else None,
        on_attempt=on_attempt,
        on_listening=on_listening,
    )
    voice = VoiceSource(
        lang, audio, hearing, robot, listen_timeout_s=times.no_speech_s, hooks=hooks
    )
    voice.end_of_speech_s = times.end_of_speech_s
    return VoiceResponses(VoiceAnswers(voice, fallback, on_fallback), voice, robot, speaker)
