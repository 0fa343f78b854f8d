"""The camera as an outcome source: what it sees answers the sensing nodes.

`CameraSource.choose` reads frames through `BenchPerception` until the world
estimate has been stable for a few frames, then maps it onto one of the node's
outcome labels (`outcome_of`). It has no answer (None, so the fallback answers)
at a node that is not a sensing node, when the estimate does not settle before
the timeout or the frames end, and when what it sees fits none of the options;
`last_observation` says which, for the panel. A look at a part's shape
(`sense(shapeOf(P))`) is answered by the outline perception reads on P's top
face, once most of its recent looks agree. When the view shows that the
person did what no outcome expects (took a part the plan did not count on, put
the part down instead of attaching it, attached it to another part), the
answer is a surprise: the executor plans again from what was seen (app.execution.repair).
With a simulated human, the human acts first, and the camera then has to see
what it did.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from app.execution.events import Evidence, Node, Outcome, describe
from app.execution.surprises import Surprise
from app.sim.human import SimulatedHuman
from perception.frames import Frame, FrameSource
from perception.pipeline import BenchPerception
from perception.world import PartEstimate, Placement, Where, WorldEstimate
from planner.vocabulary import (
    Action,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
    SenseShapeOf,
)

JPEG_WIDTH = 320  # px: enough to recognise the bench in a review, a few kB each
JPEG_QUALITY = 80
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


@dataclass(frozen=True)
class CameraObservation:
    """What the camera made of a node: the estimate that decided it and how."""

    node_id: str
    action: str | None
    world: WorldEstimate | None
    label: str | None
    reason: str
    frames: int  # frames read at this node
    seconds: float


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
                surprise = Surprise("attach", (part, p.attached_to, p.slot))
                return Reading(None, est.confidence, words, surprise)
            if p.where is Where.ON_BENCH:
                return Reading(None, est.confidence, words, Surprise("putdown", (part,)))
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
    return Reading(None, confidence, words, Surprise("take", (part,)))


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


def placements(world: WorldEstimate) -> dict[str, str]:
    """Each part's placement in words, for the stored evidence and the panel."""
    return {pid: where_words(p.placement) for pid, p in world.parts.items()}


def outlines(world: WorldEstimate) -> dict[str, str]:
    """What each looked-at face's outline reads, for the stored evidence."""
    return {
        pid: f"{p.outline.shape or 'unclear'} ({p.outline.confidence:.0%} of {p.outline.looks})"
        for pid, p in world.parts.items()
        if p.outline is not None and p.outline.looks
    }


def _seen(
    decided: tuple[str, str],
    reading: Reading,
    world: WorldEstimate,
    frame: Frame,
    frames: int,
    seconds: float,
) -> dict[str, Any]:
    """The evidence of a camera reading; `decided` is what it said ("label" or "surprise")."""
    faces = outlines(world)
    return {
        decided[0]: decided[1],
        "confidence": round(reading.confidence, 3),
        "reason": reading.reason,
        "frames": frames,
        "frame_index": frame.index,
        "seconds": round(seconds, 3),
        "placements": placements(world),
        **({"outlines": faces} if faces else {}),
    }


def camera_outcome(
    action: Action | None,
    reading: Reading,
    world: WorldEstimate,
    frame: Frame,
    frames: int,
    seconds: float,
    truth: str | None,
    picture: bytes,
) -> Outcome:
    """A camera answer with its evidence: the reading, the deciding frame, and (with a
    simulated human) what the human really did, so agreement is counted from the store."""
    assert reading.label is not None
    seen = _seen(("label", reading.label), reading, world, frame, frames, seconds)
    detail: dict[str, Any] = {"camera": seen}
    if truth is not None:
        detail["truth"] = truth
    return Outcome(
        reading.label,
        "camera",
        round(reading.confidence, 3),
        f"{describe(action, reading.label)} (camera: {reading.reason})",
        Evidence(detail, picture),
    )


def camera_surprise(
    reading: Reading,
    world: WorldEstimate,
    frame: Frame,
    frames: int,
    seconds: float,
    picture: bytes,
) -> Outcome:
    """What the camera saw that fits no outcome: the executor plans again from it."""
    assert reading.surprise is not None
    seen = _seen(("surprise", str(reading.surprise)), reading, world, frame, frames, seconds)
    return Outcome(
        "",
        "camera",
        round(reading.confidence, 3),
        f"camera: {reading.reason}",
        Evidence({"camera": seen}, picture),
        surprise=reading.surprise,
    )


def jpeg(frame: Frame, width: int = JPEG_WIDTH, quality: int = JPEG_QUALITY) -> bytes:
    """A small JPEG of a frame, for the session store and the review."""
    h, w = frame.image.shape[:2]
    image: npt.NDArray[np.integer[Any] | np.floating[Any]] = frame.image
    if w > width:
        image = cv2.resize(image, (width, round(h * width / w)), interpolation=cv2.INTER_AREA)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError("cannot encode the frame as JPEG")
    return bytes(data.tobytes())


class CameraSource:
    """Answers sensing nodes from what `frames` show, through `perception`.

    At each node it reads at least `min_frames` fresh frames (so a change made
    just before, by the human or the robot, has passed the tracker's and the
    estimate's hysteresis), then until the estimate is stable; it gives up after
    `max_frames` frames or `timeout_s` seconds. `record`, when a list, collects
    every frame read (to write a video of the run).
    """

    name = "camera"

    def __init__(
        self,
        frames: FrameSource,
        perception: BenchPerception,
        human: SimulatedHuman | None = None,
        *,
        min_frames: int | None = None,
        max_frames: int = 120,
        timeout_s: float = 10.0,
        record: list[Frame] | None = None,
    ) -> None:
        self.frames = frames
        self.perception = perception
        self.human = human
        if min_frames is None:
            settle = (
                perception.tracker.settings.confirm_frames
                + perception.estimator.settings.hysteresis_frames
            )
            min_frames = settle + perception.estimator.settings.stable_frames
        self.min_frames = min_frames
        self.max_frames = max_frames
        self.timeout_s = timeout_s
        self.record = record
        self.last_observation: CameraObservation | None = None
        self.last_frame_jpeg: bytes | None = None
        self.observations: list[CameraObservation] = []
        self._surprised: set[tuple[str, Surprise]] = set()

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        action = node.action
        if not is_sensing(action):
            return None
        start = time.monotonic()  # before the human acts: its move is part of the time
        if self.human is not None:
            self.human.act(node_id, node, options)
        world: WorldEstimate | None = None
        last: Frame | None = None
        count = 0
        reason = "no frames"
        while count < self.max_frames:
            if time.monotonic() - start > self.timeout_s:
                reason = f"no stable view within {self.timeout_s:g} s"
                break
            frame = self.frames.read()
            if frame is None:
                reason = "the frames ended"
                break
            if self.record is not None:
                self.record.append(frame)
            count += 1
            last = frame
            world = self.perception.process(frame).world
            if count >= self.min_frames and world.stable:
                break
        else:
            reason = f"no stable view within {self.max_frames} frames"
        seconds = time.monotonic() - start
        if world is None or last is None or not world.stable:
            self._keep(node_id, action, world, None, reason, count, seconds)
            return None
        reading = outcome_of(action, world, options)
        self._keep(node_id, action, world, reading.label, reading.reason, count, seconds)
        if reading.surprise is not None and (node_id, reading.surprise) not in self._surprised:
            # Said once per node: if the executor cannot follow it, the fallback answers
            # instead of the camera repeating what was already refused.
            self._surprised.add((node_id, reading.surprise))
            self.last_frame_jpeg = jpeg(last)
            return camera_surprise(reading, world, last, count, seconds, self.last_frame_jpeg)
        if reading.label is None:
            return None
        self.last_frame_jpeg = jpeg(last)
        truth = None if self.human is None else self.human.did.get(node_id)
        return camera_outcome(
            action, reading, world, last, count, seconds, truth, self.last_frame_jpeg
        )

    def _keep(
        self,
        node_id: str,
        action: Action | None,
        world: WorldEstimate | None,
        label: str | None,
        reason: str,
        frames: int,
        seconds: float,
    ) -> None:
        obs = CameraObservation(
            node_id,
            None if action is None else str(action),
            world,
            label,
            reason,
            frames,
            seconds,
        )
        self.last_observation = obs
        self.observations.append(obs)
