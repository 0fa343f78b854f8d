"""The voice's outcome source and what a live dialogue adds to it.

`VoiceAnswers` asks the questions by voice and everything else (and a question
refused twice) by the fallback; `DialogueVoice` hears its answers through an
always-listening `speech.dialogue.Ear` (a simulated room or a microphone: the
same code either way, so this module never imports a simulator). What
`voice:SOURCE` wires around them, the simulated human included, is in
`app.responses.voice`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

from app.execution.events import ExecutionControls, Outcome, OutcomeSource
from app.execution.evidence import merged
from app.execution.narration import Line, RobotVoice
from app.execution.timing import Timeline
from app.sources.stop_listener import StopListener
from app.sources.voice import (
    ANSWERS,
    Attempt,
    VoiceHooks,
    VoiceSource,
    is_question,
)
from app.sources.voice_clock import DialogueClock, DialogueTimeline, Said, WallDialogue
from planner.plan.model import PlanNode
from speech.dialogue import DialogueTimes, Ear, Hearing
from speech.languages import Language
from speech.recognition import Recognizer
from speech.sources import AudioSource

OwnVoiceListener = Callable[[str, Hearing], None]


class VoiceEnded(RuntimeError):
    """The ear's device went away while a question was asked."""


NO_HOOKS = VoiceHooks()
DEFAULT_TIMES = DialogueTimes()


class DialogueVoice(VoiceSource):
    """A `VoiceSource` that hears its answers through an always-listening `Ear`.

    Each ask waits for the ear's next answer: "no speech" after the dialogue's
    no-speech time, "too long" past its maximum utterance, the recogniser's
    verdict otherwise; what the ear refused meanwhile as the robot's own voice
    goes to `on_own_voice`. `audio` is only kept (the ear listens).
    """

    def __init__(
        self,
        language_code: str | Language,
        audio: AudioSource,
        ear: Ear,
        recognizer: Recognizer | None = None,
        voice: RobotVoice | None = None,
        hooks: VoiceHooks = NO_HOOKS,
    ) -> None:
        no_speech_s = ear.times.no_speech_s
        super().__init__(language_code, audio, recognizer, voice,
                         listen_timeout_s=no_speech_s, hooks=hooks)  # fmt: skip
        self.ear = ear
        self.end_of_speech_s = ear.times.end_of_speech_s
        self.on_own_voice: OwnVoiceListener | None = None
        self.wall_of: Callable[[float], float] | None = None  # the ear's stream time on the wall
        self._asked_from = 0  # the ear's hearings since the question was asked
        # Before the line is played: the narrator's first ask, or the voice's own.
        self.voice.listeners.insert(0, self._line_said)

    def _line_said(self, line: Line) -> None:
        if line.node_id:  # a line of the plan (the dialogue's own have none)
            self._asked_from = len(self.ear.heard)

    def interrupt(self) -> None:
        super().interrupt()
        self.ear.interrupt()

    def choose(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        if self.ear.lost is not None:
            return None  # the device went away: the voice has ended
        return super().choose(node_id, node, options)

    def _listen(self, node_id: str, number: int) -> Attempt:
        if self.on_listening is not None:
            self.on_listening(True)
        try:
            answer = self.ear.answer(self.recognizer)
        finally:
            if self.on_listening is not None:
                self.on_listening(False)
        if self.ear.lost is not None:
            raise VoiceEnded(self.ear.lost)
        own = [h for h in self.ear.heard[self._asked_from :] if h.reason == "own voice"]
        own += [h for h in answer.own_voice if h not in own]
        for hearing in own:
            if self.on_own_voice is not None:
                self.on_own_voice(node_id, hearing)
        heard = answer.hearing
        if heard is None:
            return Attempt(node_id, number, (), 0.0, None, answer.reason)
        meaning = heard.meaning if heard.meaning in ANSWERS else None
        reason = heard.reason or (None if meaning else "out of grammar")
        return Attempt(
            node_id, number, heard.words, heard.confidence, meaning, reason, heard.origin
        )


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
        stops: StopListener | None = None,
    ) -> None:
        self.voice = voice
        self.fallback = fallback
        self.on_fallback = on_fallback
        self.stops = stops
        self.controls: ExecutionControls | None = None
        self._given_up: str | None = None
        self._told = voice.on_attempt
        # Told when the execution ends (the microphone's speakers fall silent).
        self.on_detach: list[Callable[[], None]] = []
        voice.on_attempt = self._attempted
        if isinstance(voice, DialogueVoice):
            voice.on_own_voice = self._own_voice

    # -- the execution that runs (the walker attaches and detaches its source)

    def attach(self, controls: ExecutionControls) -> None:
        self.controls = controls
        if self.stops is not None:
            self.stops.attach(controls)
        clock = dialogue_clock(getattr(controls, "timeline", None), self.voice)
        if isinstance(self.voice, DialogueVoice):
            # The live ear times what it hears itself, in real time: on the wall clock.
            if clock is not None and clock.clock == "wall":
                self.voice.ear.on_heard = self._heard_live
        else:
            self.voice.clock = clock

    def detach(self, controls: ExecutionControls) -> None:
        self.controls = None
        self.voice.clock = None
        if self.stops is not None:
            self.stops.attach(None)
        if isinstance(self.voice, DialogueVoice):
            self.voice.ear.on_heard = None
            self.voice.ear.close()
        for closing in self.on_detach:
            closing()

    def hold(self, held: bool) -> None:
        """The execution paused (True) or went on: a live ear takes no answer while
        paused, and must take them again however the execution resumed."""
        if isinstance(self.voice, DialogueVoice):
            self.voice.ear.hold(held)

    def _attempted(self, attempt: Attempt) -> None:
        """Each try: told on, the human's speech kept, and a refusal kept as the
        dialogue's turn."""
        if self._told is not None:
            self._told(attempt)
        controls = self.controls
        if controls is None:
            return
        if attempt.said is not None:
            words = speech_words(attempt.heard, attempt.meaning, attempt.reason)
            controls.observe_human(*attempt.said, words, "voice", node_id=attempt.node_id)
        if attempt.accepted:
            return
        if attempt.reason == "too long" and isinstance(self.voice, DialogueVoice):
            limit = self.voice.ear.times.max_utterance_s
            controls.note("too-long", f"an utterance over {limit:g} s: not an answer",
                          "voice", node_id=attempt.node_id)  # fmt: skip
        if attempt.number < self.voice.tries:
            controls.note("asked-again", f"asked again ({attempt.reason})", "voice",
                          node_id=attempt.node_id)  # fmt: skip

    def _heard_live(self, hearing: Hearing) -> None:
        """An utterance the live ear heard (its thread): the human's speech, on the wall
        clock, unless it was the robot's own voice."""
        controls = self.controls
        wall_of = self.voice.wall_of if isinstance(self.voice, DialogueVoice) else None
        if controls is None or wall_of is None or hearing.reason == "own voice":
            return
        said = Said(wall_of(hearing.start_s), wall_of(hearing.spoken_until_s))
        words = speech_words(" ".join(hearing.words), hearing.meaning or hearing.command,
                             hearing.reason)  # fmt: skip
        controls.observe_human(*said, words, "voice")

    def voice_ended(self, why: str) -> None:
        """The live ear lost its device (told in its thread): kept at once as a turn of
        the dialogue, so whoever shows the execution stops saying that the voice
        listens; each question after it falls back as well (`_fell_back`)."""
        if self.controls is not None:
            self.controls.note("fell-back", f"the voice has ended ({why}): the fallback "
                               "answers from now on", "voice")  # fmt: skip

    def _own_voice(self, node_id: str, hearing: Hearing) -> None:
        if self.controls is not None:
            heard = f" ('{' '.join(hearing.words)}')" if hearing.words else ""
            self.controls.note("own-voice", f"the robot's own voice{heard}: not an answer",
                               "voice", node_id=node_id)  # fmt: skip

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
            if outcome is None:
                self._fell_back(node_id)
        answer = self.fallback.choose(node_id, node, options)
        if answer is None:
            return None
        heard = self.voice.evidence(node_id)
        hearing = heard.voice
        if hearing is not None:
            hearing = replace(hearing, answered_by="fallback", fallback=answer.source)
        return replace(answer, evidence=merged(answer.evidence, replace(heard, voice=hearing)))

    def _fell_back(self, node_id: str) -> None:
        summary = self.voice.summary(node_id)
        lost = self.voice.ear.lost if isinstance(self.voice, DialogueVoice) else None
        if lost is not None:
            summary = f"the voice has ended: {lost}"
        elif self.on_fallback is not None:  # a lost voice was said once, when it was lost
            self.on_fallback(node_id, summary)
        if self.controls is not None:
            self.controls.note("fell-back", f"no voice answer ({summary}): the fallback answers",
                               "voice", node_id=node_id)  # fmt: skip

    def _by_voice(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        try:
            return self.voice.choose(node_id, node, options)
        except VoiceEnded:
            return None  # said once, when the ear lost its device
        except Exception as error:  # a broken device or file must not stop the session
            if self.on_fallback is not None:
                self.on_fallback(node_id, f"the voice failed: {error}")
            return None

    def _clicked(self, node_id: str) -> bool:
        clicked = getattr(self.fallback, "clicked", None)
        return bool(clicked(node_id)) if callable(clicked) else False


def dialogue_clock(timeline: Timeline | None, voice: VoiceSource) -> DialogueClock | None:
    """The clock the voice's turns go on while `timeline` runs: the wall clock, a
    `DialogueTimeline`, or none (another simulated clock draws the answers' times)."""
    if isinstance(timeline, DialogueTimeline):
        return timeline
    if timeline is not None and timeline.clock == "wall":
        return WallDialogue(voice.wait, voice.end_of_speech_s)
    return None


def speech_words(heard: str, meaning: str | None, reason: str | None) -> str:
    """The human's speech in words, for its event."""
    if meaning is not None:
        return f"the human says: {heard} ({meaning})"
    words = f"'{heard}', " if heard else ""
    return f"the human speaks ({words}refused: {reason})" if reason else "the human speaks"
