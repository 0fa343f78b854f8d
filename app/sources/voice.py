"""Answers to the robot's questions by voice: speak, listen, recognise, decide.

`VoiceSource` is the `OutcomeSource` for the yes/no questions (askHelp,
offerHelp, confirmAttach). At such a node it speaks the node's sentence
(`speech.synthesis.synthesize`), listens on an `AudioSource` (microphone, WAV
files, or the simulated voice) and hands the audio to a closed-grammar
`Recognizer` (vosk or pocketsphinx, whichever hears the language). A refused
result (silence, low confidence, out of grammar, ambiguous) makes it ask once
more; a second refusal is "no answer" (None), so a `FallbackSource` takes the
answer from clicks (or, headless, from a random or expected choice). A misheard
answer would send the plan down the wrong branch, so only what the recogniser
accepted ever becomes an outcome.

Every attempt is kept per node (`attempts`), with the words heard, the
confidence and why it was refused, so a session can say whether an answer
came from the voice or, after which refusals, from the fallback:
`evidence(node_id)` is that record as the session stores it (words, confidence,
meaning, tries, engine, and what the simulated human really said when one did).

The simulated human's mouth (`app.sim.speaker.SimulatedSpeaker`) is told through
`on_question` when the robot has asked, and its `truth` fills the evidence; this
module never imports it.

The first ask is the narrator's when it said the question as the executor reached
the node (the walk then waited for it on the wall clock); the voice says it again
before each later try. With a `clock` (`app.sources.voice_clock`, set while an
execution runs) each try is timed on the execution's clock, and the human's speech
(voice-activity onset to the end of speech) is kept on its `Attempt` (`said`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from app.execution.events import AnswerSource, Outcome
from app.execution.evidence import Evidence, HeardAttempt, Truth, VoiceHearing
from app.execution.narration import Line, RobotVoice
from app.sources.voice_clock import DialogueClock, Said, line_seconds
from planner.plan.model import PlanNode
from planner.vocabulary import QUESTIONS
from speech.audio import Recording
from speech.languages import Language, language
from speech.recognition import Heard, Recognizer
from speech.sources import AudioSource, MicrophoneSource, RoomMicrophone
from speech.voice_activity import speech_span

ANSWERS = ("yes", "no")

# Told (node_id, node, options) once the robot has spoken a question and
# before it listens, on every attempt: how a simulated human knows when to speak.
QuestionListener = Callable[[str, PlanNode, Sequence[str]], None]
# What really was said at a node (a simulated human knows), for the evidence.
TruthOf = Callable[[str], Truth | None]
# Told each attempt as it is heard (the dashboard shows the last words).
AttemptListener = Callable[["Attempt"], None]
# Told True when listening starts and False when it ends (the listening indicator).
ListeningListener = Callable[[bool], None]


def is_question(node: PlanNode, options: Sequence[str]) -> bool:
    """A yes/no question to the human: the only nodes a voice can answer."""
    return (
        node.action is not None
        and node.action.name in QUESTIONS
        and bool(options)
        and set(options) <= set(ANSWERS)
    )


@dataclass(frozen=True)
class Asked:
    """One sentence the robot said, and the engine that said it."""

    node_id: str
    text: str
    engine: str
    duration_s: float | None = None  # its audio (None: not spoken)


@dataclass(frozen=True)
class Attempt:
    """One ask-and-listen at a node: what was heard and what it was taken to mean."""

    node_id: str
    number: int  # 1 for the first ask, 2 for the second
    words: tuple[str, ...]
    confidence: float
    meaning: str | None  # "yes"/"no" when accepted
    reason: str | None  # why it was refused (None when accepted)
    origin: str = ""  # where the audio came from ("microphone", a file, "simulated:...")
    said: Said | None = None  # when the human spoke, on the execution's clock (if timed)

    @property
    def accepted(self) -> bool:
        return self.meaning is not None

    @property
    def heard(self) -> str:
        return " ".join(self.words)


@dataclass(frozen=True)
class VoiceHooks:
    """Who is told what while the voice asks and listens (each optional)."""

    on_question: QuestionListener | None = None  # the robot has asked: a simulated human speaks
    truth: TruthOf | None = None  # what was really said, for the evidence
    on_attempt: AttemptListener | None = None  # each try as it is heard
    on_listening: ListeningListener | None = None  # listening starts and ends


class VoiceSource:
    """Yes/no answers heard through `audio` and a closed grammar for the language.

    `recognizer` may be shared (the model is costly to load); without one a
    `Recognizer` for `language_code` is made. `voice` is the `RobotVoice` that
    speaks (shared with the narrator, so every line reaches the same listeners;
    without one, the language's default engines). `tries` is how many times a
    question is asked before giving up to the fallback; `hooks` who is told what.
    """

    name: AnswerSource = "voice"

    def __init__(
        self,
        language_code: str | Language,
        audio: AudioSource,
        recognizer: Recognizer | None = None,
        voice: RobotVoice | None = None,
        *,
        listen_timeout_s: float = 5.0,
        tries: int = 2,
        hooks: VoiceHooks = VoiceHooks(),
    ) -> None:
        self.language = (
            language_code if isinstance(language_code, Language) else language(language_code)
        )
        self.recognizer = recognizer if recognizer is not None else Recognizer(self.language)
        if self.recognizer.language.code != self.language.code:
            raise ValueError(
                f"the recogniser hears {self.recognizer.language.code}, "
                f"the questions are asked in {self.language.code}"
            )
        self.audio = audio
        self.voice = voice if voice is not None else RobotVoice(self.language)
        self.listen_timeout_s = listen_timeout_s
        self.tries = tries
        self.on_question = hooks.on_question
        self.truth = hooks.truth
        self.on_attempt = hooks.on_attempt
        self.on_listening = hooks.on_listening
        self.spoken: list[Asked] = []
        self.attempts: dict[str, list[Attempt]] = {}
        self.last_heard: Attempt | None = None
        self.clock: DialogueClock | None = None  # the execution's, while one runs
        self.end_of_speech_s = 0.2  # the pause that ends an answer (the dialogue's)
        self._interrupted = threading.Event()
        self._lines_seen = 0  # the robot's lines said before the question now asked

    # -- speaking -------------------------------------------------------------

    def speak(self, node_id: str, text: str) -> Asked:
        """Says `text` and records which engine said it ("none" if none could)."""
        began = self.clock.now() if self.clock is not None else None
        asked = _asked(self.voice.say(node_id, text))
        self.spoken.append(asked)
        if self.clock is not None:
            self.clock.said(line_seconds(text, asked.duration_s), began)
        return asked

    def _ask(self, node_id: str, text: str, number: int) -> None:
        """The question said: the narrator's line at the first try, if it said it."""
        narrated = None
        if number == 1:
            said = self.voice.lines[self._lines_seen :]
            narrated = next(
                (line for line in reversed(said) if (line.node_id, line.text) == (node_id, text)),
                None,
            )
        if narrated is None:
            self.speak(node_id, text)
        else:
            asked = _asked(narrated)
            self.spoken.append(asked)
            if self.clock is not None:  # the walk waited for it on the wall clock
                self.clock.said(line_seconds(text, asked.duration_s), None)
        self._lines_seen = len(self.voice.lines)

    # -- answering ------------------------------------------------------------

    def interrupt(self) -> None:
        """The next (or current, between attempts) `choose` gives up at once."""
        self._interrupted.set()

    def wait(self, seconds: float) -> None:
        """Waits `seconds`, or less when interrupted meanwhile."""
        self._interrupted.wait(seconds)

    def choose(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        if not is_question(node, options) or not node.say:
            return None  # sensing and silent nodes are for other sources
        records = self.attempts.setdefault(node_id, [])
        if self.clock is not None:
            self.clock.asking(node)
        for number in range(1, self.tries + 1):
            if self._interrupted.is_set():
                self._interrupted.clear()
                return None
            self._ask(node_id, node.say, number)
            if self.on_question is not None:
                self.on_question(node_id, node, options)
            attempt = self._listen(node_id, number)
            records.append(attempt)
            self.last_heard = attempt
            if self.on_attempt is not None:
                self.on_attempt(attempt)
            if attempt.meaning is not None and attempt.meaning in options:
                return Outcome(
                    attempt.meaning,
                    self.name,
                    attempt.confidence,
                    text=f"heard '{attempt.heard}'",
                    evidence=self.evidence(node_id),
                )
        return None  # refused every time: the fallback answers

    def _listen(self, node_id: str, number: int) -> Attempt:
        if self.on_listening is not None:
            self.on_listening(True)
        began = self.clock.now() if self.clock is not None else 0.0
        decoding = None
        try:
            if isinstance(self.audio, MicrophoneSource | RoomMicrophone):
                # Decoded while it is spoken: the answer comes right after the pause.
                decoding = self.recognizer.start()
                recording = self.audio.listen(self.listen_timeout_s, decoding.feed)
            else:
                recording = self.audio.listen(self.listen_timeout_s)
        finally:
            if self.on_listening is not None:
                self.on_listening(False)
        if recording is None:
            # Nothing came within the timeout: the same refusal as a silent clip.
            self._timed(None, None, began)
            return Attempt(node_id, number, (), 0.0, None, "silence")
        heard: Heard = (
            decoding.finish()
            if decoding is not None
            else self.recognizer.recognize(recording.samples, recording.rate)
        )
        said = self._timed(recording, heard, began)
        return Attempt(
            node_id,
            number,
            heard.words,
            heard.confidence,
            heard.meaning,
            heard.reason,
            recording.origin,
            said,
        )

    def _timed(self, recording: Recording | None, heard: Heard | None, began: float) -> Said | None:
        """When the human spoke in `recording` (None: nothing heard, or silence), on the
        clock, which goes on to when the answer was taken."""
        if self.clock is None:
            return None
        speech = None
        if recording is not None and heard is not None and heard.reason != "silence":
            speech = speech_span(recording.samples, recording.rate)
        return self.clock.listened(recording, speech, began, self.listen_timeout_s)

    # -- what happened ----------------------------------------------------------

    def evidence(self, node_id: str) -> Evidence:
        """What the session keeps of the voice at a question (after the last try)."""
        tried = self.attempts.get(node_id, [])
        last = tried[-1] if tried else None
        spoken = [s for s in self.spoken if s.node_id == node_id]
        hearing = VoiceHearing(
            answered_by="voice" if last is not None and last.accepted else "fallback",
            heard=last.heard if last is not None else "",
            confidence=round(last.confidence, 3) if last is not None else 0.0,
            meaning=last.meaning if last is not None else None,
            tries=len(tried),
            attempts=tuple(
                HeardAttempt(a.heard, round(a.confidence, 3), a.meaning, a.reason, a.origin)
                for a in tried
            ),
            engine=spoken[-1].engine if spoken else "none",
            recognizer=self.recognizer.description,
        )
        truth = self.truth(node_id) if self.truth is not None else None
        return Evidence(voice=hearing, truth=truth)

    def summary(self, node_id: str) -> str:
        """One line for a session log: how the question at `node_id` was answered."""
        tried = self.attempts.get(node_id, [])
        if not tried:
            return "not asked by voice"
        parts = [
            f"heard '{a.heard}' ({a.meaning})" if a.accepted else f"refused '{a.heard}': {a.reason}"
            for a in tried
        ]
        return "; ".join(parts)


def _asked(line: Line) -> Asked:
    utterance = line.utterance
    return Asked(line.node_id, line.text, line.engine,
                 utterance.duration_s if utterance is not None else None)  # fmt: skip
