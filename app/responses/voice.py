"""`--responses voice:SOURCE`: the voice answers the questions of an execution.

SOURCE is `sim` (a seeded simulated human chooses each answer, randomly or
from a script, and says it through espeak-ng into the real recogniser), `mic`
(the default microphone) or a folder of WAV files (one answer a file, in name
order). The robot speaks every communication node as it is reached
(`RobotVoice` as the executor's narrator; the questions are spoken by the
voice source before each listen). Nodes the voice does not answer (sensing,
or a question refused twice) go to the fallback; every question's event
carries the voice's evidence either way, so a session says which answered.

No speech model for the language is `NoSpeechModel` (one line); no
microphone is `NoAudioDevice`; a missing folder `FileNotFoundError`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from app.execution.events import Outcome, OutcomeSource
from app.execution.evidence import merged
from app.execution.narration import LineListener, RobotVoice
from app.sim.speaker import SimulatedSpeaker
from app.sources.outcomes import ScriptedSource
from app.sources.voice import (
    AttemptListener,
    ListeningListener,
    VoiceHooks,
    VoiceSource,
    is_question,
)
from planner.plan.model import PlanNode
from speech.languages import language
from speech.recognition import Recognizer
from speech.sources import AudioSource, MicrophoneSource, SimulatedVoice, WavFolderSource
from speech.synthesis import Engine


class VoiceAnswers:
    """Questions by voice, everything else (and a question refused twice) by `fallback`.

    A fallback that can show its choices at once (the dashboard's clicks) shows
    them while the voice listens, and a click that comes first wins; a question
    the voice gave up on stays with the fallback while it has no answer yet.
    """

    def __init__(
        self,
        voice: VoiceSource,
        fallback: OutcomeSource,
        on_fallback: Callable[[str, str], None] | None = None,
    ) -> None:
        self.voice = voice
        self.fallback = fallback
        self.on_fallback = on_fallback
        self._given_up: str | None = None

    def interrupt(self) -> None:
        self.voice.interrupt()
        interrupt = getattr(self.fallback, "interrupt", None)
        if callable(interrupt):
            interrupt()

    def choose(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        if not is_question(node, options) or not node.say:
            return self.fallback.choose(node_id, node, options)
        if self._given_up != node_id:
            offer = getattr(self.fallback, "offer", None)
            if callable(offer):
                offer(node_id, options, node.action)
            outcome = self._by_voice(node_id, node, options)
            if outcome is not None and not self._clicked(node_id):
                withdraw = getattr(self.fallback, "withdraw", None)
                if callable(withdraw):
                    withdraw(node_id)
                return outcome
            self._given_up = node_id
            if self.on_fallback is not None and outcome is None:
                self.on_fallback(node_id, self.voice.summary(node_id))
        answer = self.fallback.choose(node_id, node, options)
        if answer is None:
            return None
        heard = self.voice.evidence(node_id)
        hearing = heard.voice
        if hearing is not None:
            hearing = replace(hearing, answered_by="fallback", fallback=answer.source)
        return replace(answer, evidence=merged(answer.evidence, replace(heard, voice=hearing)))

    def _by_voice(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        try:
            return self.voice.choose(node_id, node, options)
        except Exception as error:  # a broken device or file must not stop the session
            if self.on_fallback is not None:
                self.on_fallback(node_id, f"the voice failed: {error}")
            return None

    def _clicked(self, node_id: str) -> bool:
        clicked = getattr(self.fallback, "clicked", None)
        return bool(clicked(node_id)) if callable(clicked) else False


@dataclass
class VoiceResponses:
    """What `voice:SOURCE` wires: the outcome source, the robot's voice (the
    executor's narrator) and, for `sim`, the simulated speaker."""

    source: VoiceAnswers
    voice: VoiceSource
    robot: RobotVoice
    speaker: SimulatedSpeaker | None


def human_script(human: str) -> list[str]:
    """The answer labels of `--human scripted:FILE` (none for `random`)."""
    if human == "random":
        return []
    if human.startswith("scripted:") and human != "scripted:":
        return [line.label for line in ScriptedSource(human[len("scripted:") :]).lines]
    raise ValueError(f"--human {human}: expected random or scripted:FILE")


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
) -> VoiceResponses:
    """The voice source for `voice:SOURCE` (see the module docstring for the errors)."""
    lang = language(language_code)
    # The model first: without one nothing else is worth opening.
    hearing = recognizer if recognizer is not None else Recognizer(lang, model_dir)
    speaker: SimulatedSpeaker | None = None
    audio: AudioSource
    if spec == "sim":
        speaker = SimulatedSpeaker(SimulatedVoice(lang, seed=seed), seed=seed,
                                   script=human_script(human))  # fmt: skip
        audio = speaker.voice
    elif spec == "mic":
        audio = MicrophoneSource()
    else:
        audio = WavFolderSource(spec)
    robot = RobotVoice(lang, engine, cache_dir, [on_line] if on_line else [], questions=False)
    hooks = VoiceHooks(
        on_question=speaker,
        truth=speaker.truth if speaker is not None else None,
        on_attempt=on_attempt,
        on_listening=on_listening,
    )
    voice = VoiceSource(lang, audio, hearing, robot, hooks=hooks)
    return VoiceResponses(VoiceAnswers(voice, fallback, on_fallback), voice, robot, speaker)
