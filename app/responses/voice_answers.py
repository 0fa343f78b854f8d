"""What `voice:SOURCE` wires (`VoiceResponses`), shared by its three ways of
wiring it (`app.responses.voice`, `voice_room`, `voice_mic`).

The voice's outcome sources themselves (`VoiceAnswers`, `DialogueVoice`) are
in `app.sources.voice_answers`: they run the same with a person or a simulator,
while `VoiceResponses` also holds the simulated human and room, so it stays
here with the simulators' wiring.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.execution.narration import RobotVoice
from app.sim.speaker import SimulatedSpeaker
from app.sources.outcomes import ScriptedSource
from app.sources.stop_listener import StopListener
from app.sources.voice import VoiceSource
from app.sources.voice_answers import VoiceAnswers
from speech.dialogue import Ear
from speech.sources import SimulatedRoom


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


def human_script(human: str) -> list[str]:
    """The answer labels of `--human scripted:FILE` (none for `random`)."""
    if human == "random":
        return []
    if human.startswith("scripted:") and human != "scripted:":
        return [line.label for line in ScriptedSource(human[len("scripted:") :]).lines]
    raise ValueError(f"--human {human}: expected random or scripted:FILE")
