"""Where a spoken question and its answers fall on the execution's clock.

A question asked by voice lasts as its dialogue does: the robot says the
question (its audio's length), the human answers (the answer's speech, from
its voice-activity onset to the end of its last loud frame), the ear waits the
end-of-speech pause, and a refusal has the question said again. The human's
speech is the human's activity, kept as a `human` event of source `voice`.

- `WallDialogue`, on the wall clock: a microphone's audio carries the wall time
  of its first sample, so the speech is where it was heard; audio that has no
  time of its own (a simulated voice, a file) is heard from when the listening
  began, and the voice waits until it has been heard to its end.
- `DialogueTimeline`, on a simulated clock: a `SimulatedTimeline` on which a
  question the voice answers lasts as its dialogue did (a question the voice
  does not answer keeps the drawn answer time); the answer's audio is placed
  from the moment the robot listened, so its speech lies within the question's
  wait. No audio within the no-speech time is that time waited.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, Protocol

from app.execution.events import Clock
from app.execution.evidence import Evidence
from app.execution.timing import SimulatedTimeline, StepTimes, speech_seconds
from planner.plan.model import Motion, PlanNode
from planner.scenario.sections import Human
from speech.audio import Recording
from speech.voice_activity import SpeechSpan


class Said(NamedTuple):
    """When the human spoke, on the execution's clock (epoch seconds)."""

    start: float
    end: float


class DialogueClock(Protocol):
    """The clock a voice's turns are timed on (see the module)."""

    clock: Clock

    def asking(self, node: PlanNode) -> None:
        """The question at `node` is being asked (its step began)."""
        ...

    def said(self, seconds: float, began: float | None) -> None:
        """The robot said a line lasting `seconds`, begun at `began` (None: already
        waited for, by the walk)."""
        ...

    def listened(
        self,
        recording: Recording | None,
        speech: SpeechSpan | None,
        began: float,
        no_speech_s: float,
    ) -> Said | None:
        """The listening begun at `began` heard `recording` (None: nothing), whose
        speech is `speech`; when the human spoke, if they did."""
        ...

    def now(self) -> float: ...


def line_seconds(text: str, duration_s: float | None) -> float:
    """How long a line lasts: its audio, or its words at espeak-ng's rate."""
    return duration_s if duration_s is not None else speech_seconds(text, None)


class WallDialogue:
    """The wall clock; `wait` sleeps, returning early when the voice is interrupted."""

    clock: Clock = "wall"

    def __init__(self, wait: Callable[[float], object], end_of_speech_s: float = 0.2) -> None:
        self.wait = wait
        self.end_of_speech_s = end_of_speech_s

    def asking(self, node: PlanNode) -> None:
        pass

    def said(self, seconds: float, began: float | None) -> None:
        # Speakers that play in the background (the page) still have the line to say.
        if began is not None:
            self._until(began + seconds)

    def listened(
        self,
        recording: Recording | None,
        speech: SpeechSpan | None,
        began: float,
        no_speech_s: float,
    ) -> Said | None:
        if recording is None or speech is None:
            return None
        if recording.recorded_at is not None:  # heard live: its own wall times
            start = recording.recorded_at
        else:  # heard from when the listening began, to its end
            start = began
            self._until(start + speech.end_s + self.end_of_speech_s)
        return Said(start + speech.start_s, start + speech.end_s)

    def now(self) -> float:
        return time.time()

    def _until(self, at: float) -> None:
        left = at - time.time()
        if left > 0:
            self.wait(left)


@dataclass
class _Asking:
    """The question under way on a simulated clock: its node, its start, when the
    robot began waiting, and where the dialogue stands."""

    node: PlanNode
    start: float
    at: float
    wait_start: float | None = None


class DialogueTimeline(SimulatedTimeline):
    """A simulated clock on which a question the voice answers lasts as its dialogue
    (see the module); `human` also gives the end-of-speech pause."""

    def __init__(self, seed: int, human: Human | None = None, origin: float | None = None):
        super().__init__(seed, human, origin)
        self.end_of_speech_s = (human or Human()).end_of_speech_s
        self._asking: _Asking | None = None

    # -- the dialogue (the voice's thread is the walk's: it answers within the step)

    def asking(self, node: PlanNode) -> None:
        if self._asking is None or self._asking.node is not node:
            self._asking = _Asking(node, self.robot_free, self.robot_free)

    def said(self, seconds: float, began: float | None) -> None:
        if self._asking is not None:
            self._asking.at += seconds

    def listened(
        self,
        recording: Recording | None,
        speech: SpeechSpan | None,
        began: float,
        no_speech_s: float,
    ) -> Said | None:
        asking = self._asking
        if asking is None:
            return None
        if asking.wait_start is None:
            asking.wait_start = asking.at
        if recording is None or speech is None:
            asking.at += no_speech_s  # nobody spoke: the ear waited its no-speech time
            return None
        heard_from = asking.at
        asking.at += speech.end_s + self.end_of_speech_s
        return Said(heard_from + speech.start_s, heard_from + speech.end_s)

    # -- the timeline

    def begin(self, node: PlanNode) -> float:
        if self._asking is not None and self._asking.node is not node:
            self._asking = None  # a question left for another node (a surprise)
        return super().begin(node)

    def finish(self, node: PlanNode, spoken: Evidence | None, motion: Motion | None) -> StepTimes:
        asking, self._asking = self._asking, None
        if asking is None or asking.node is not node:
            return super().finish(node, spoken, motion)
        self.robot_free = asking.at
        return StepTimes(asking.start, asking.at, asking.wait_start)

    def now(self) -> float:
        return self._asking.at if self._asking is not None else self.robot_free
