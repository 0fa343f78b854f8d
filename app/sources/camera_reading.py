"""What a settled view of the bench says at a sensing node.

`outcome_of` maps a world estimate onto one of a node's outcome labels, or says
why none fits; when the view shows that the person did what no outcome expects
(took a part the plan did not count on, put the part down instead of attaching
it, attached it to another part), the reading carries that surprise, for the
executor to plan again from (app.execution.repair). A look at a part's shape
(`sense(shapeOf(P))`) is answered by the outline perception reads on P's top
face, once most of its recent looks agree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from app.execution.surprises import HumanAttached, HumanPutDown, HumanTook, Surprise
from perception.world import PartEstimate, Placement, Where, WorldEstimate
from planner.vocabulary import (
    Action,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
    SenseShapeOf,
)

# A face's outline is an answer once this share of its recent looks read it, over
# at least this many looks: one blurred frame must not decide what a part is.
OUTLINE_AGREEMENT = 0.6
OUTLINE_LOOKS = 5


@dataclass(frozen=True)
class Reading:
    """An estimate mapped onto a node: the label it fits (or None, and why), or what
    the person did that no outcome of the node expects (`surprise`)."""

    label: str | None
    confidence: float
    reason: str
    surprise: Surprise | None = None


def is_sensing(action: Action | None) -> bool:
    return isinstance(
        action,
        SenseHumanHolding
        | SenseHumanHoldingWhichPart
        | SenseHumanUnholding
        | SenseHumanAttachingWhere
        | SenseShapeOf,
    )


def outcome_of(action: Action | None, world: WorldEstimate, options: Sequence[str]) -> Reading:
    """The outcome of a sensing `action` that `world` shows, if it is one of `options`."""
    human = world.human
    match action:
        case SenseHumanHolding():
            label = "yes" if human.holding else "no"
            if human.holding and "yes" not in options:
                # The plan counted on no more initiative: the human took a part anyway.
                return _took(human.holding[0], human.confidence)
            words = (
                f"the human holds {', '.join(human.holding)}"
                if human.holding
                else "the human's hands are free"
            )
            return _fit(label, human.confidence, words, options)
        case SenseHumanHoldingWhichPart():
            if not human.holding:
                return Reading(None, human.confidence, "the human's hands look free")
            held = [p for p in human.holding if p in options]
            if not held:
                return _took(human.holding[0], human.confidence)
            return Reading(held[0], world.parts[held[0]].confidence, f"the human holds {held[0]}")
        case SenseHumanUnholding(part):
            est = world.parts.get(part)
            if est is None:
                return Reading(None, 0.0, f"{part} is not on this bench")
            if est.where is Where.HELD_BY_HUMAN:
                return _fit("no", est.confidence, f"{part} is in the human's hands", options)
            if est.where in (Where.ON_BENCH, Where.ATTACHED):
                words = f"{part} is {where_words(est.placement)}"
                return _fit("yes", est.confidence, words, options)
            return Reading(None, est.confidence, f"{part} is {where_words(est.placement)}")
        case SenseHumanAttachingWhere(part, onto):
            est = world.parts.get(part)
            if est is None:
                return Reading(None, 0.0, f"{part} is not on this bench")
            p = est.placement
            if p.where is Where.ATTACHED and p.attached_to == onto and p.slot is not None:
                return _fit(p.slot, est.confidence, f"{part} is on {onto} at {p.slot}", options)
            words = f"{part} is {where_words(p)}, not on {onto}"
            if p.where is Where.ATTACHED and p.attached_to is not None and p.slot is not None:
                surprise = HumanAttached(part, p.attached_to, p.slot)
                return Reading(None, est.confidence, words, surprise)
            if p.where is Where.ON_BENCH:
                return Reading(None, est.confidence, words, HumanPutDown(part))
            return Reading(None, est.confidence, words)
        case SenseShapeOf(part):
            return _outline_reading(world, part, options)
    return Reading(None, 0.0, "not a sensing node")


def _outline_reading(world: WorldEstimate, part: str, options: Sequence[str]) -> Reading:
    """The shape of `part`'s face as its recent looks read it (the labels of a
    shapeOf node are the shapes themselves)."""
    est = world.parts.get(part)
    if est is None:
        return Reading(None, 0.0, f"{part} is not on this bench")
    outline = est.outline
    if outline is None or outline.looks == 0:
        return Reading(None, 0.0, f"{part}'s face has not been in view")
    if outline.shape is None:
        return Reading(None, 0.0, f"{part}'s face is not clear in {outline.looks} looks")
    share = f"{outline.confidence:.0%} of {outline.looks} looks"
    words = f"{part}'s face looks {outline.shape} in {share}"
    if outline.looks < OUTLINE_LOOKS or outline.confidence < OUTLINE_AGREEMENT:
        return Reading(None, outline.confidence, f"{words}: not yet a steady reading")
    return _fit(outline.shape, outline.confidence, words, options)


def _took(part: str, confidence: float) -> Reading:
    words = f"the human holds {part}, which no outcome here expects"
    return Reading(None, confidence, words, HumanTook(part))


def _fit(label: str, confidence: float, words: str, options: Sequence[str]) -> Reading:
    if label in options:
        return Reading(label, confidence, words)
    return Reading(None, confidence, f"{words}: '{label}' is not one of {', '.join(options)}")


def where_words(p: Placement) -> str:
    """Where a placement puts a part, in words."""
    match p.where:
        case Where.ON_BENCH:
            return f"on the bench in {p.region}"
        case Where.HELD_BY_HUMAN:
            return "in the human's hands"
        case Where.HELD_BY_ROBOT:
            return "in the robot's gripper"
        case Where.ATTACHED:
            return f"attached to {p.attached_to} at {p.slot}"
    return "out of sight"


def belief_words(p: PartEstimate) -> str:
    """Where a part is, and for one whose shape is open what its face looks like."""
    words = where_words(p.placement)
    if p.outline is not None and p.outline.shape is not None:
        words += f", looks {p.outline.shape} ({p.outline.confidence:.0%})"
    return words
