"""The execution log in sentences: what the robot did or said, and who answered how.

Pure (no viser): `sentence(event)` is one line of the log. The robot's own
words, when it spoke them, are the line; else the action in words ("The robot
holds leg1 with its left arm"). An answered node adds what was answered, by
whom (click, camera, voice, random...) and how sure; a voice answer adds what
was heard.
"""

from __future__ import annotations

from app.execution.events import ExecutionEvent
from planner.vocabulary import (
    Attach,
    Hold,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
    SenseLengthOf,
    SenseShapeOf,
    Unhold,
)

WHO = {
    "click": "a click",
    "console": "the console",
    "random": "a random choice",
    "scripted": "the script",
    "expected": "the expected branch",
    "camera": "the camera",
    "voice": "the voice",
}


def action_words(action: object) -> str:
    """An action as a sentence; communication falls back to its term."""
    match action:
        case Hold(arm=arm, part=part):
            return f"The robot holds {part} with its {arm} arm."
        case Attach(arm=arm, onto=onto, slot=slot):
            return f"The robot's {arm} arm attaches its part to {onto} at {slot}."
        case Unhold(arm=arm):
            return f"The robot's {arm} arm lets go."
        case SenseHumanHolding():
            return "The robot looks whether the human holds a part."
        case SenseHumanHoldingWhichPart():
            return "The robot looks which part the human holds."
        case SenseHumanUnholding(part=part):
            return f"The robot looks whether the human let go of {part}."
        case SenseHumanAttachingWhere(part=part, onto=onto):
            return f"The robot looks where the human attaches {part} on {onto}."
        case SenseShapeOf(part=part):
            return f"The robot looks at the shape of {part}."
        case SenseLengthOf(part=part):
            return f"The robot measures {part}."
        case None:
            return "The goal is reached."
    return f"The robot: {action}."


def answer_words(event: ExecutionEvent) -> str:
    """Who answered the node's question and how sure ("" when nothing was asked)."""
    if event.outcome is None or event.source is None:
        return ""
    who = WHO.get(event.source, event.source)
    sure = ""
    if event.confidence is not None and event.source != "click":  # a click is sure
        sure = f", {event.confidence:.0%} sure"
    heard = ""
    voice = event.evidence.voice if event.evidence is not None else None
    if voice is not None and voice.heard:
        heard = f", heard “{voice.heard}”"
    return f" → **{event.outcome}** (by {who}{sure}{heard})"


# The dialogue's own turns (app/execution/events.py `DialogueKind`), in words.
DIALOGUE_WORDS = {
    "paused": "The human said stop: the robot stopped.",
    "resumed": "The human said continue: the robot goes on.",
    "own-voice": "Heard while the robot spoke: its own voice, not an answer.",
    "too-long": "The human spoke too long for an answer.",
    "asked-again": "No answer heard: the robot asks again.",
    "fell-back": "Still no answer by voice: the clicks answer.",
}


def sentence(event: ExecutionEvent) -> str:
    """One line of the log for `event`, with its node id for the tree."""
    if event.kind in DIALOGUE_WORDS:
        heard = f" (heard “{event.text}”)" if event.text else ""
        return f"`{event.node}` *{DIALOGUE_WORDS[event.kind]}*{heard}"
    if event.kind == "human":  # the simulated human's own action, in a timed run
        return f"`{event.node}` *The human: {event.text or 'acts'}.*"
    if event.kind == "repair":
        words = event.text or "The robot plans again from what it saw."
    elif event.kind == "interrupted":
        words = event.text or "The execution was interrupted."
    elif event.kind == "robot-fault":
        return f"`{event.node}` **The robot stopped:** {event.text or 'a fault'}"
    elif event.text and event.kind == "communication":
        words = f"The robot says: “{event.text}”"
    else:
        words = action_words(event.action)
    return f"`{event.node}` {words}{answer_words(event)}"
