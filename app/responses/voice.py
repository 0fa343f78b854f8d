"""`--responses voice:SOURCE`: the voice answers the questions of an execution.

SOURCE is `sim` (a seeded simulated human chooses each answer, randomly or
from a script, and says it through espeak-ng into the real recogniser), `mic`
(the default microphone) or a folder of WAV files (one answer a file, in name
order). The robot speaks every communication node as it is reached
(`RobotVoice` as the executor's narrator; the questions are spoken by the
voice source before each listen). Nodes the voice does not answer (sensing,
or a question refused twice) go to the fallback; every question's event
carries the voice's evidence either way, so a session says which answered.

With `live=True` (`sim` only) the dialogue listens all the time, as it would
in a room (`speech.dialogue`): the robot's sentences and the simulated human's
words share one simulated microphone in real time, the robot never takes its
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

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from app.execution.events import ExecutionControls, Outcome, OutcomeSource
from app.execution.evidence import merged
from app.execution.narration import Line, LineListener, RobotVoice
from app.execution.timing import Timeline
from app.sim.speaker import SimulatedSpeaker
from app.sources.outcomes import ScriptedSource
from app.sources.stop_listener import StopListener
from app.sources.voice import (
    ANSWERS,
    Attempt,
    AttemptListener,
    ListeningListener,
    VoiceHooks,
    VoiceSource,
    is_question,
)
from app.sources.voice_clock import DialogueClock, DialogueTimeline, Said, WallDialogue
from planner.plan.model import PlanNode
from planner.scenario.sections import Human
from speech.audio import RATE, read_wav, resample
from speech.dialogue import BLOCK_S, Commands, DialogueTimes, Ear, Hearing
from speech.languages import Language, language
from speech.recognition import Recognizer
from speech.sources import (
    AudioSource,
    MicrophoneSource,
    SimulatedRoom,
    SimulatedVoice,
    WavFolderSource,
)
from speech.synthesis import Engine

OwnVoiceListener = Callable[[str, Hearing], None]
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

    def _listen(self, node_id: str, number: int) -> Attempt:
        if self.on_listening is not None:
            self.on_listening(True)
        try:
            answer = self.ear.answer(self.recognizer)
        finally:
            if self.on_listening is not None:
                self.on_listening(False)
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
        span = self.room.play_robot(samples)
        self.ear.robot_speaks(samples, span.start_s)
        while self.room.position_s < min(span.end_s, self.room.robot_until_s):
            time.sleep(BLOCK_S)

    def stop(self) -> None:
        """The robot falls silent now."""
        self.room.cut_robot()
        self.ear.robot_stopped(self.room.now_s())


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
        if self.on_fallback is not None:
            self.on_fallback(node_id, summary)
        if self.controls is not None:
            self.controls.note("fell-back", f"no voice answer ({summary}): the fallback answers",
                               "voice", node_id=node_id)  # fmt: skip

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


@dataclass
class VoiceResponses:
    """What `voice:SOURCE` wires: the outcome source, the robot's voice (the
    executor's narrator) and, for `sim`, the simulated speaker."""

    source: VoiceAnswers
    voice: VoiceSource
    robot: RobotVoice
    speaker: SimulatedSpeaker | None
    room: SimulatedRoom | None = None  # live: the simulated microphone's room
    ear: Ear | None = None  # live: what listens all the time
    stops: StopListener | None = None  # live: "stop" and "continue"


def dialogue_times(human: Human) -> DialogueTimes:
    """The dialogue's times from a scenario's `[human]` section."""
    return DialogueTimes(human.no_speech_s, human.end_of_speech_s, human.max_utterance_s)


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
    live: bool = False,
    times: DialogueTimes = DEFAULT_TIMES,
) -> VoiceResponses:
    """The voice source for `voice:SOURCE` (see the module docstring for the errors);
    `live` (with `sim`) listens all the time, within the dialogue's `times`."""
    lang = language(language_code)
    # The model first: without one nothing else is worth opening.
    hearing = recognizer if recognizer is not None else Recognizer(lang, model_dir)
    lines = [on_line] if on_line else []
    if live:
        if spec != "sim":
            raise ValueError("a live dialogue is simulated only (voice:sim)")
        hooks = VoiceHooks(on_attempt=on_attempt, on_listening=on_listening)
        wiring = LiveDialogue(lang, hearing, times, cache_dir, model_dir)
        return wiring.responses(fallback, seed, human, lines, hooks, on_fallback)
    speaker: SimulatedSpeaker | None = None
    audio: AudioSource
    if spec == "sim":
        speaker = SimulatedSpeaker(SimulatedVoice(lang, seed=seed), seed=seed,
                                   script=human_script(human))  # fmt: skip
        audio = speaker.voice
    elif spec == "mic":
        audio = MicrophoneSource(pause_s=times.end_of_speech_s, max_s=times.max_utterance_s)
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
        ear.on_command = stops
        hooks = replace(hooks, on_question=speaker, truth=speaker.truth)
        voice = DialogueVoice(self.language, speaker.voice, ear, self.recognizer, robot, hooks)
        voice.wall_of = room.wall_s
        ear.start()
        answers = VoiceAnswers(voice, fallback, on_fallback, stops)
        return VoiceResponses(answers, voice, robot, speaker, room, ear, stops)
