"""Stop and continue at any time: the human's voice pauses and resumes an execution.

`StopListener` is the `speech.dialogue.Ear`'s command listener. On "stop" it
pauses the execution at once (an arm motion under way stops at its next
waypoint; the executor holds the ear, so no answer is taken while paused, and
lets it go on however the execution resumes), silences the robot
(`on_stop`, the speakers) and has the robot say that it stopped; on "continue"
it resumes and says it goes on. The pause and the resume are kept as events
(`paused`, `resumed`) with what was heard. The ear calls it from its own
thread; the robot's sentence is said in another, so listening goes on meanwhile.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from app.execution.events import ExecutionControls
from app.execution.evidence import Evidence, HeardAttempt, VoiceHearing
from app.execution.narration import GOING_ON, STOPPED, RobotVoice
from speech.dialogue import Command, Ear, Hearing


@dataclass(frozen=True)
class Pause:
    """One pause by voice: the words and where, on the ear's clock, it was heard and
    the execution paused (seconds of stream time)."""

    words: tuple[str, ...]
    heard_s: float
    paused_s: float


class StopListener:
    """Pauses and resumes whichever execution is `attach`ed (see the module)."""

    def __init__(
        self, ear: Ear, robot: RobotVoice, on_stop: Callable[[], None] | None = None
    ) -> None:
        self.ear = ear
        self.robot = robot
        self.on_stop = on_stop
        self.controls: ExecutionControls | None = None
        self.pauses: list[Pause] = []
        self._saying: threading.Thread | None = None

    def attach(self, controls: ExecutionControls | None) -> None:
        self.controls = controls

    def __call__(self, command: Command, hearing: Hearing) -> None:
        controls = self.controls
        if controls is None:
            return
        words = " ".join(hearing.words)
        commands = self.ear.commands
        engine = commands.recognizer.description if commands is not None else ""
        evidence = Evidence(voice=_hearing(command, hearing, f"{engine}, commands"))
        if command == "stop":
            controls.pause(f"heard '{words}': the robot stops", evidence)
            self.pauses.append(Pause(hearing.words, hearing.end_s, self.ear.stream.position_s))
            if self.on_stop is not None:
                self.on_stop()
            self._say(STOPPED)
        else:
            controls.resume(f"heard '{words}': the robot goes on", evidence)
            self._say(GOING_ON)

    def _say(self, phrases: dict[str, str]) -> None:
        text = phrases.get(self.robot.language.code, phrases["en-us"])
        # No node of the plan says it: the line belongs to the dialogue.
        self._saying = threading.Thread(
            target=self.robot.say, args=("", text), name="robot-says", daemon=True
        )
        self._saying.start()

    def said(self, timeout_s: float) -> None:
        """Returns once the robot has said that it stopped or goes on (or `timeout_s`)."""
        saying = self._saying
        if saying is not None:
            saying.join(timeout_s)


def _hearing(command: Command, hearing: Hearing, recognizer: str) -> VoiceHearing:
    """The command as the session keeps it: what was heard and what it meant."""
    words = " ".join(hearing.words)
    confidence = round(hearing.confidence, 3)
    return VoiceHearing(
        answered_by="voice",
        heard=words,
        confidence=confidence,
        meaning=command,
        tries=1,
        attempts=(HeardAttempt(words, confidence, command, None, hearing.origin),),
        recognizer=recognizer,
    )
