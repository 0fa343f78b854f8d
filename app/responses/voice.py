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

With `Conversation(live=True)` (`sim`; `app.responses.voice_room`) the dialogue listens all
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
from dataclasses import dataclass, replace
from pathlib import Path

from app.execution.events import OutcomeSource
from app.execution.narration import LineListener, RobotVoice
from app.responses.voice_answers import VoiceResponses, human_script
from app.responses.voice_mic import MicDialogue, Speakers
from app.responses.voice_room import LiveDialogue
from app.sim.speaker import SimulatedSpeaker
from app.sources.voice import AttemptListener, ListeningListener, VoiceHooks, VoiceSource
from app.sources.voice_answers import DEFAULT_TIMES, VoiceAnswers
from planner.scenario.sections import Human
from speech.dialogue import DialogueTimes
from speech.languages import Language, language
from speech.recognition import Recognizer
from speech.sources import AudioSource, SimulatedVoice, WavFolderSource
from speech.synthesis import Engine

__all__ = [
    "DEFAULT_TIMES", "Conversation", "SpeechModels", "VoiceListeners", "VoiceResponses",
    "dialogue_times", "voice_responses",
]  # fmt: skip


@dataclass(frozen=True)
class Conversation:
    """How the dialogue goes: within its `times`; with `voice:sim`, the simulated human
    who answers (seeded by `seed`, and the room with it; `human` is `random` or
    `scripted:FILE`), in a room that listens all the time (`live`) or turn by turn;
    with `voice:mic`, where the robot's lines play (`speakers`: `local`, the
    dashboard's `page`, or `none`)."""

    times: DialogueTimes = DEFAULT_TIMES
    live: bool = False
    seed: int | None = None
    human: str = "random"
    speakers: Speakers = "local"


@dataclass(frozen=True)
class SpeechModels:
    """What hears and what speaks: the recogniser (`recognizer`, one already loaded,
    or else one loaded from `model_dir`, which also holds the command words' model;
    None: the language's own) and the robot's synthesiser (`engine`, its
    utterances kept in `cache_dir`)."""

    recognizer: Recognizer | None = None
    model_dir: Path | str | None = None
    engine: Engine = "auto"
    cache_dir: Path | None = None


@dataclass(frozen=True)
class VoiceListeners:
    """Who is told, as it happens: each line the robot says (`on_line`), each try at
    an answer (`on_attempt`), the voice starting and stopping to listen
    (`on_listening`), a question left to the fallback (`on_fallback`: the node and
    why); with `voice:mic`, in one line each, that the microphone went away
    (`on_lost`) or that a line could not be played (`on_unplayed`)."""

    on_line: LineListener | None = None
    on_attempt: AttemptListener | None = None
    on_listening: ListeningListener | None = None
    on_fallback: Callable[[str, str], None] | None = None
    on_lost: Callable[[str], None] | None = None
    on_unplayed: Callable[[str], None] | None = None

    def lines(self) -> list[LineListener]:
        """Who hears of each line the robot says (the robot's voice's listeners)."""
        return [self.on_line] if self.on_line is not None else []


def dialogue_times(human: Human) -> DialogueTimes:
    """The dialogue's times from a scenario's `[human]` section."""
    return DialogueTimes(human.no_speech_s, human.end_of_speech_s, human.max_utterance_s)


def voice_responses(
    spec: str,
    language_code: str,
    fallback: OutcomeSource,
    *,
    conversation: Conversation = Conversation(),
    speech: SpeechModels = SpeechModels(),
    told: VoiceListeners = VoiceListeners(),
) -> VoiceResponses:
    """The voice source for `voice:SOURCE` (see the module docstring for the errors);
    a `live` conversation (with `sim`) listens all the time, within the dialogue's
    times; `mic` always does (`app.responses.voice_mic`)."""
    lang = language(language_code)
    # The model first: without one nothing else is worth opening.
    if speech.recognizer is None:
        speech = replace(speech, recognizer=Recognizer(lang, speech.model_dir))
    if spec != "mic" and not conversation.live:
        return _turn_by_turn(spec, lang, fallback, conversation, speech, told)
    if spec not in ("mic", "sim"):
        raise ValueError("a live simulated dialogue is voice:sim (voice:mic is always live)")
    return _always_listening(spec == "mic", lang, fallback, conversation, speech, told)


def _always_listening(
    mic: bool,
    lang: Language,
    fallback: OutcomeSource,
    conversation: Conversation,
    speech: SpeechModels,
    told: VoiceListeners,
) -> VoiceResponses:
    """The microphone's dialogue, or the simulated room's (`voice_mic`, `voice_room`)."""
    assert speech.recognizer is not None  # loaded by voice_responses
    hooks = VoiceHooks(on_attempt=told.on_attempt, on_listening=told.on_listening)
    times, cache_dir, model_dir = conversation.times, speech.cache_dir, speech.model_dir
    if mic:
        dialogue = MicDialogue(lang, speech.recognizer, times, cache_dir, model_dir,
                               conversation.speakers)  # fmt: skip
        return dialogue.responses(fallback, told.lines(), hooks, told.on_fallback,
                                  told.on_lost, told.on_unplayed, speech.engine)  # fmt: skip
    room = LiveDialogue(lang, speech.recognizer, times, cache_dir, model_dir)
    return room.responses(fallback, conversation.seed, conversation.human, told.lines(), hooks,
                          told.on_fallback)  # fmt: skip


def _turn_by_turn(
    spec: str,
    lang: Language,
    fallback: OutcomeSource,
    conversation: Conversation,
    speech: SpeechModels,
    told: VoiceListeners,
) -> VoiceResponses:
    """`voice:sim` (not live) or a folder of WAV files: the voice listens only after
    each question, to the simulated human's answer or to the folder's next file."""
    speaker: SimulatedSpeaker | None = None
    audio: AudioSource
    if spec == "sim":
        seed = conversation.seed
        speaker = SimulatedSpeaker(SimulatedVoice(lang, seed=seed), seed=seed,
                                   script=human_script(conversation.human))  # fmt: skip
        audio = speaker.voice
    else:
        audio = WavFolderSource(spec)
    robot = RobotVoice(lang, speech.engine, speech.cache_dir, told.lines())
    hooks = VoiceHooks(
        on_question=speaker,
        truth=speaker.truth if speaker is not None else None,
        on_attempt=told.on_attempt,
        on_listening=told.on_listening,
    )
    times = conversation.times
    voice = VoiceSource(lang, audio, speech.recognizer, robot,
                        listen_timeout_s=times.no_speech_s, hooks=hooks)  # fmt: skip
    voice.end_of_speech_s = times.end_of_speech_s
    return VoiceResponses(VoiceAnswers(voice, fallback, told.on_fallback), voice, robot, speaker)
