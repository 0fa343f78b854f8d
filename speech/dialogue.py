"""A dialogue that listens all the time: answers, the robot's own voice, timeouts, commands.

`Ear` reads a live `BlockStream` (the simulated room, or a microphone) in its
own thread and cuts it into utterances (`EndOfSpeech`, with the dialogue's
end-of-speech pause and maximum utterance). Each utterance is decoded while it
is spoken, by the command grammar always and by the answer grammar while an
answer is awaited (`Ear.answer`; asked late, the first utterance begun after
the robot's question, ended or not, from its first block), and is then judged:

- **Never hearing itself.** The robot tells the ear what it says and when
  (`robot_speaks`). An utterance that starts while the robot speaks, or within
  `echo_tail_s` after, is never an answer ("own voice"); it is cut at the end
  of that window, so an answer that starts right after is heard on its own.
  Where the robot's audio is known sample for sample (the simulated room),
  `voice_activity.EchoCanceller` also subtracts it from what the microphone hears, so a
  person can still be heard over the robot (a "stop" said while it speaks).
- **Timeouts.** No utterance within `no_speech_s` of the robot's last word is
  "no speech"; an utterance cut by `max_utterance_s` is "too long" (and the
  rest of it is ignored until the next pause). Either ends the wait, so the
  question is asked again and then falls back, as a refusal does. The
  no-speech time runs on the stream's clock, which stands still when no audio
  comes (a device that hangs, an ear whose thread failed): a wait that gets no
  audio for `no_speech_s` of wall time ends too ("no audio"), so an answer wait
  always ends, unless the execution is paused (held) and the stream goes on.
  A stream that fails (a device unplugged) ends the ear (`lost`, `on_lost`);
  the ear's thread is the stream's only reader and closes it as it ends.
- **Commands.** "stop" (and "wait", 멈춰, 잠깐, 정지) and "continue" (계속,
  계속해) are heard at any time, with the recogniser's rejection strategy on a
  grammar of the commands (the answers and the language's distractor words
  absorb everything else); `on_command` is told. A "continue" in the robot's
  own voice window is ignored (the robot must never resume itself); a "stop"
  is taken, since stopping is always safe, but only where the robot's voice is
  cancelled: without the canceller the window holds the robot's own words (its
  closing line, 테이블이 완성됐어요…, was once heard as 멈춰 and paused the
  run). A "continue", and a stop while an answer is awaited, is checked
  against the answers (`Commands.confirms`): an answer the command grammar
  forced into a command ("no" as "resume") is not one; a stop mid-motion is
  taken at once. While the ear is `held` (the execution is paused) no answer
  is taken and the no-speech time does not run.

Measured on espeak-ng's voices (12 each: variants, speeds, pitches, half
with noise). Korean (vosk): 멈춰 9/12, 잠깐 9/12, 잠깐만 6/12, 정지 7/12 taken
as stop; 계속 11/12, 계속해 12/12 as continue; of 84 non-commands (answers,
words, sentences) one (네) was taken as a command; 그만 (1/12) was dropped.
English (pocketsphinx, which has no distractor words): stop 9/12, wait 12/12;
continue 11/12, resume 12/12; "hold on" and "go on" were dropped (each heard
as the other); of 96 non-commands 11 were taken ("okay" 4 and "table" 1 as
stop, which only pauses; "no", "hello there" 3 each as continue, which only
acts while paused). A person repeats a command the robot did not obey.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from speech.audio import BLOCK, RATE, Samples, level_db
from speech.commands import COMMAND_WORDS, Command, Commands
from speech.recognition import Decoding, Recognizer
from speech.sources import BlockStream
from speech.voice_activity import FRAME_S, EchoCanceller, EndOfSpeech, activity

__all__ = [
    "BLOCK_S", "COMMAND_WORDS", "Answer", "Command", "Commands", "DialogueTimes", "Ear",
    "Hearing",
]  # fmt: skip

BLOCK_S = BLOCK / RATE
# Why the dialogue (not the recogniser) refused what it heard.
DialogueRefusal = Literal["no speech", "no audio", "own voice", "too long"]


@dataclass(frozen=True)
class DialogueTimes:
    """The dialogue's three times and the self-hearing tail, in seconds.

    Furhat's SDK waits 5 s for speech, 0.8 s of silence and 15 s of speech.
    `no_speech_s` keeps its 5 s. `end_of_speech_s` is 0.2 s: an answer here is
    one to three words with no pause inside, and the answer can only be taken
    once the pause has passed (0.2 s brings the decision within 0.3 s of the
    end of speech; the same answers were heard at 0.35 s). `max_utterance_s` is 5 s: answers and
    commands last at most 1.5 s at espeak-ng's slowest speed, so anything much
    longer is talk, not an answer, and 15 s would only delay asking again.
    """

    no_speech_s: float = 5.0
    end_of_speech_s: float = 0.2
    max_utterance_s: float = 5.0
    echo_tail_s: float = 0.3


@dataclass(frozen=True)
class Hearing:
    """One utterance the ear heard and what it made of it.

    `meaning` is the answer ("yes"/"no") and `command` the command, when taken;
    otherwise `reason` says why not (a `DialogueRefusal` or the recogniser's).
    Stream times: `start_s` the voice activity's onset, `end_s` when the ear ended
    the utterance (after the end-of-speech pause), `speech_end_s` the end of its
    speech (its last loud block).
    """

    start_s: float
    end_s: float
    words: tuple[str, ...] = ()
    confidence: float = 0.0
    meaning: str | None = None
    command: Command | None = None
    reason: str | None = None
    speech_end_s: float | None = None  # None: `end_s`

    @property
    def spoken_until_s(self) -> float:
        return self.end_s if self.speech_end_s is None else self.speech_end_s

    @property
    def origin(self) -> str:
        return f"live:{self.start_s:.2f}-{self.end_s:.2f}s"


@dataclass
class Answer:
    """What `Ear.answer` waited for: the utterance that ended the wait (None: no
    speech) and the robot's own voice refused meanwhile."""

    hearing: Hearing | None
    own_voice: list[Hearing] = field(default_factory=list)
    no_audio: bool = False  # ended because the stream gave no audio

    @property
    def reason(self) -> str | None:
        if self.hearing is None:
            return "no audio" if self.no_audio else "no speech"
        return self.hearing.reason


CommandListener = Callable[[Command, Hearing], None]
# Told every utterance the ear heard, as it ends (in the ear's thread).
HearingListener = Callable[[Hearing], None]


@dataclass
class _Utterance:
    """The utterance being heard: where it started, its decodings, whether it is own."""

    start_s: float
    own: bool
    commands: Decoding | None
    answers: Decoding | None
    blocks: list[Samples] = field(default_factory=list)  # its audio (`Commands.confirms`)


class Ear:
    """Listens to `stream` in its own thread (see the module docstring).

    `cancel_echo` subtracts the robot's audio (only where it is sample-aligned
    with the stream, as in `SimulatedRoom`). `heard` keeps every utterance.
    """

    def __init__(
        self,
        stream: BlockStream,
        times: DialogueTimes = DialogueTimes(),
        commands: Commands | None = None,
        on_command: CommandListener | None = None,
        *,
        cancel_echo: bool = True,
        start_db: float = 12.0,
    ) -> None:
        self.stream = stream
        self.times = times
        self.commands = commands
        self.on_command = on_command
        self.on_heard: HearingListener | None = None
        self.on_lost: Callable[[str], None] | None = None  # the stream failed (one line)
        self.lost: str | None = None  # why the stream failed, once it has
        self.canceller = EchoCanceller() if cancel_echo else None
        self.cut = EndOfSpeech(BLOCK_S, start_db, times.end_of_speech_s, times.max_utterance_s)
        self.heard: list[Hearing] = []
        self.held = False
        self._cond = threading.Condition(threading.RLock())
        self._robot: list[tuple[float, float]] = []  # when the robot spoke (stream time)
        # Its own lock, taken last: the robot may be told of while a room holds its own
        # lock (`SimulatedRoom.play_robot`), which the ear's thread takes under `_cond`.
        self._robot_lock = threading.Lock()
        self._awaiting: Recognizer | None = None
        self._answer: Answer | None = None
        self._current: _Utterance | None = None
        self._unasked: list[tuple[_Utterance, Hearing]] = []  # heard while no answer awaited
        self._waited_until_s = 0.0  # where the last answer's wait ended (stream time)
        self._draining = False  # the rest of a too-long utterance
        self._recent: list[tuple[float, Samples]] = []  # the pre-roll before an onset
        self._levels: list[float] = []  # dBFS of the recent blocks between utterances
        self._closed = False
        self._interrupted = False
        self._quiet_from = 0.0  # the no-speech time of an answer counts from here
        self._thread = threading.Thread(target=self._run, name="ear", daemon=True)

    # -- what the owner says and asks (any thread) --------------------------------

    def start(self) -> Ear:
        self._thread.start()
        return self

    def close(self, wait_s: float = 1.0) -> None:
        """Stops listening; the stream (a device) is released before this returns, once
        the read under way has ended (within `wait_s`)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        if self._thread is threading.current_thread():
            return  # the ear's own thread releases it as it ends
        if self._thread.is_alive():
            self._thread.join(wait_s)
        elif self._thread.ident is None:  # never started: nobody else will release it
            close = getattr(self.stream, "close", None)
            if callable(close):
                close()

    def robot_speaks(self, samples: Samples, start_s: float) -> None:
        """The robot says `samples` from stream time `start_s` (as played); its voice
        ends with its last loud frame (espeak-ng ends on ~0.3 s of silence)."""
        loud = np.flatnonzero(activity(samples, RATE).active)
        end_s = start_s + (loud[-1] + 1) * FRAME_S if loud.size else start_s
        with self._robot_lock:
            self._robot.append((start_s, end_s))
        if self.canceller is not None:
            self.canceller.add(samples, start_s)

    def robot_stopped(self, at_s: float) -> None:
        """The robot fell silent at `at_s`, before the end of what it was saying."""
        with self._robot_lock:
            self._robot = [(start, min(end, at_s)) for start, end in self._robot]
        if self.canceller is not None:
            self.canceller.cut(at_s)

    def interrupt(self) -> None:
        """The answer being waited for (or the next) is given up at once."""
        with self._cond:
            self._interrupted = True
            self._cond.notify_all()

    @property
    def robot_until_s(self) -> float:
        """The end of the self-hearing window: the robot's last word and the tail."""
        with self._robot_lock:
            last = max((end for _, end in self._robot), default=0.0)
        return last + self.times.echo_tail_s

    def hold(self, held: bool) -> None:
        """Paused (True): no answer is taken and the no-speech time stands still."""
        with self._cond:
            self.held = held
            self._cond.notify_all()

    def answer(self, recognizer: Recognizer, no_speech_s: float | None = None) -> Answer:
        """The next utterance heard as an answer by `recognizer`, once the robot has
        finished speaking; "no speech" after `no_speech_s` (default the dialogue's)."""
        wait = self.times.no_speech_s if no_speech_s is None else no_speech_s
        with self._cond:
            self._awaiting, self._answer = recognizer, Answer(None)
            self._catch_up(recognizer, self._answer)
            self._quiet_from = self.stream.position_s
            heard_at, position = time.monotonic(), self.stream.position_s
            try:
                while not self._closed and not self._interrupted:
                    if self._answer.hearing is not None or self._silent_for(wait):
                        break
                    if self.stream.position_s != position:
                        heard_at, position = time.monotonic(), self.stream.position_s
                    elif time.monotonic() - heard_at >= wait:
                        # No audio for the no-speech time on the wall clock: the stream's
                        # time stands still (a device that hangs, an ear that died), so
                        # its no-speech time would never pass.
                        self._answer.no_audio = True
                        break
                    self._cond.wait(BLOCK_S)
                self._interrupted = False
                return self._answer
            finally:
                self._awaiting = None
                self._waited_until_s = self.stream.position_s

    def _catch_up(self, recognizer: Recognizer, answer: Answer) -> None:
        """What was heard of the robot's last question before the answer was asked for
        (under the lock): its own voice, and the first utterance begun after it.

        The asking thread may reach `answer` late (a busy machine, or an ear catching
        up on its stream, which takes the lock block after block), after a quick
        human has begun or even finished answering: that utterance is decoded from its
        first block, as if the wait had begun in time. One begun before the question
        is not an answer.
        """
        with self._robot_lock:
            asked_s = self._robot[-1][0] if self._robot else None
        unasked, self._unasked = self._unasked, []
        # Only a question the ear was told of since the last wait (a line the page
        # plays as MP3 is not): otherwise what came after an older one is no answer.
        if asked_s is None or asked_s < self._waited_until_s or self.held:
            return
        answer.own_voice = [h for h in self.heard if h.reason == "own voice" and h.end_s > asked_s]
        after = [(u, h) for u, h in unasked if u.start_s + BLOCK_S > asked_s]  # onset after it
        if after:
            utterance, heard = after[0]
            self._decode(utterance, recognizer)
            hearing = replace(self._judged(utterance, False, heard.end_s),
                              speech_end_s=heard.speech_end_s)  # fmt: skip
            self.heard = [hearing if h is heard else h for h in self.heard]
            answer.hearing = hearing
            return
        current = self._current
        if current is not None and not current.own and current.answers is None:
            if current.start_s + BLOCK_S > asked_s:
                self._decode(current, recognizer)

    @staticmethod
    def _decode(utterance: _Utterance, recognizer: Recognizer) -> None:
        """`utterance`'s answer decoding, from its first block."""
        utterance.answers = recognizer.start()
        for block in utterance.blocks:
            utterance.answers.feed(block)

    def _silent_for(self, wait: float) -> bool:
        """Whether nobody has spoken for `wait` s since the robot stopped, not counting
        the time held or spent in an utterance (under the lock)."""
        now = self.stream.position_s
        if self.held or self._current is not None:
            self._quiet_from = now
            return False
        return now - max(self._quiet_from, self.robot_until_s) >= wait

    # -- the thread -------------------------------------------------------------

    def _run(self) -> None:
        try:
            while not self._closed:
                block = self.stream.read()
                end_s = self.stream.position_s
                if self.canceller is not None:
                    block = self.canceller.cancel(block, end_s)
                with self._cond:
                    self._hear(block, end_s)
                    self._cond.notify_all()
        except Exception as error:  # the device went away: the ear ends, the owner is told
            self._lose(" ".join(str(error).split()) or type(error).__name__)
        finally:
            # The ear is the stream's only reader: it releases the device, on every exit.
            close = getattr(self.stream, "close", None)
            if callable(close):
                close()

    def _lose(self, why: str) -> None:
        with self._cond:
            self.lost, self._closed = why, True
            self._cond.notify_all()
        if self.on_lost is not None:
            self.on_lost(why)

    def _in_window(self, at_s: float) -> bool:
        tail = self.times.echo_tail_s
        with self._robot_lock:
            return any(start <= at_s <= end + tail for start, end in self._robot)

    def _hear(self, block: Samples, end_s: float) -> None:
        """One block, under the lock: an utterance starts, goes on or ends."""
        self._recent = [*self._recent[-9:], (end_s, block)]  # 0.3 s of pre-roll
        if self._draining:
            self.cut.feed(block)
            if self.cut.floor is not None and self.cut.quiet_s >= self.times.end_of_speech_s:
                self._draining = False
                self.cut.restart()
            return
        if self._current is None:
            self._follow_floor(block)
        ended = self.cut.feed(block)
        if self._current is None:
            if self.cut.started_at is None:
                return
            self._current = self._begin(end_s)
            # The pre-roll, but none of the robot's window: an answer heard on its own.
            window = self.robot_until_s
            for ended_s, piece in self._recent:
                if self._current.own or ended_s > window:
                    self._feed(piece)
        else:
            self._feed(block)
        current = self._current
        if current.own and end_s >= self.robot_until_s:
            ended = True  # the window is over: what follows is heard on its own
        if ended:
            self._end(current, end_s)

    def _follow_floor(self, block: Samples) -> None:
        """The noise floor of the last 3 s between utterances: the room's quiet, not
        whatever (the robot's voice) was heard when listening began."""
        self._levels = [*self._levels[-99:], level_db(block)]
        if len(self._levels) >= 10:
            self.cut.floor = float(np.percentile(self._levels, 10))

    def _begin(self, onset_s: float) -> _Utterance:
        """An utterance whose onset is in the block ending at `onset_s`."""
        own = self._in_window(onset_s)
        commands = self.commands.start() if self.commands is not None else None
        answering = self._awaiting is not None and not self.held
        answers = self._awaiting.start() if answering and self._awaiting else None
        return _Utterance(onset_s - BLOCK_S, own, commands, answers)

    def _feed(self, block: Samples) -> None:
        assert self._current is not None
        self._current.blocks.append(block)
        for decoding in (self._current.commands, self._current.answers):
            if decoding is not None:
                decoding.feed(block)

    def _end(self, current: _Utterance, end_s: float) -> None:
        too_long = self.cut.too_long
        spoken_until = end_s - self.cut.quiet_s
        self._current = None
        if too_long:
            self._draining = True
        else:
            self.cut.restart()
        command = self._command(current, too_long, end_s)
        if command is not None:
            command = replace(command, speech_end_s=spoken_until)
            self._heard(command)
            if self.on_command is not None:
                self.on_command(command.command or "stop", command)
            return
        hearing = replace(self._judged(current, too_long, end_s), speech_end_s=spoken_until)
        self._heard(hearing)
        if self._awaiting is None or self._answer is None:
            if not current.own and not too_long:  # an answer asked for late may be this
                self._unasked = [*self._unasked[-3:], (current, hearing)]
            return
        if hearing.reason == "own voice":
            self._answer.own_voice.append(hearing)
        elif current.answers is not None:
            self._answer.hearing = hearing

    def _heard(self, hearing: Hearing) -> None:
        self.heard.append(hearing)
        if self.on_heard is not None:
            self.on_heard(hearing)

    def _command(self, current: _Utterance, too_long: bool, end_s: float) -> Hearing | None:
        if current.commands is None or too_long:
            return None
        heard = current.commands.finish()
        command = Commands.command_of(heard)
        # In the robot's window only a stop is taken, and only when the robot's
        # voice is cancelled: otherwise the window holds the robot's own words.
        if command is None or (current.own and (command == "continue" or self.canceller is None)):
            return None
        assert self.commands is not None
        # Checked against the answers while one is awaited, and a "continue" always; a
        # stop mid-motion is not (it only pauses, and a check would delay it).
        checked = command == "continue" or current.answers is not None
        if checked and not self.commands.confirms(command, np.concatenate(current.blocks)):
            return None  # an answer the command grammar forced into a command
        return Hearing(current.start_s, end_s, heard.words, heard.confidence, command=command)

    def _judged(self, current: _Utterance, too_long: bool, end_s: float) -> Hearing:
        refusal: DialogueRefusal | None = (
            "own voice" if current.own else "too long" if too_long else None
        )
        if current.answers is None:
            return Hearing(current.start_s, end_s, reason=refusal)
        heard = current.answers.finish()
        return Hearing(
            current.start_s, end_s, heard.words, heard.confidence,
            meaning=None if refusal else heard.meaning, reason=refusal or heard.reason,
        )  # fmt: skip
