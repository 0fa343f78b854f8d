"""The camera as an outcome source: what it sees answers the sensing nodes.

`CameraSource.choose` looks at the views of a `ViewFeed` (app/sources/camera_feed.py:
frames it pulls through `BenchPerception`, or a live camera's views) until the
world estimate has been stable for a few fresh views, then maps it onto one of
the node's outcome labels (app/sources/camera_reading.py). It is one logic for
both feeds: a headless run and the dashboard's live camera decide alike, and a
surprise (the person did what no outcome expects) reaches the executor, which
plans again from what was seen (app.execution.repair), whichever feed saw it.

It has no answer (None, so the fallback answers) at a node that is not a sensing
node, when no stable view comes before the limits or the views end, and when what
it sees fits none of the options and is no surprise; `last_observation` says
which, for the panel. What happens before it looks is a `BeforeLook`: in a
simulated run a simulated human acts out an outcome (app.sim implements it; a
source never imports the simulators), and the camera then has to see what it did.
Without one, a person acts in their own time: a view that fits nothing yet is
watched on until one fits or the limits end the look.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import cv2
import numpy as np
import numpy.typing as npt

from app.execution.events import (
    AnswerSource,
    ExecutionControls,
    Interruptible,
    Node,
    Outcome,
    describe,
)
from app.execution.evidence import CameraDecision, CameraReading, Evidence, Truth
from app.execution.surprises import Surprise
from app.sources.camera_feed import View, ViewFeed, settle_frames
from app.sources.camera_reading import Reading, is_sensing, outcome_of, where_words
from perception.frames import Frame
from perception.world import WorldEstimate
from planner.vocabulary import Action

JPEG_WIDTH = 320  # px: enough to recognise the bench in a review, a few kB each
JPEG_QUALITY = 80


class BeforeLook(Protocol):
    """What happens at a sensing node before the camera looks. In a simulated run a
    simulated human acts out an outcome there (app.sim.human implements this), so
    the camera, not the simulator, says which branch is taken."""

    def before_look(self, node_id: str, node: Node, options: Sequence[str]) -> bool:
        """Acts at the node; False when nothing is to be looked at (whoever says what
        happens had no answer, e.g. no click before an abort)."""
        ...

    def truth(self, node_id: str) -> str | None:
        """The outcome that really happened at `node_id`, when known (it is kept with
        the camera's answer, so agreement is counted from the store)."""
        ...


class ExecutionWatch(Protocol):
    """Whoever watches the execution beside the camera's answers (the human's actions a
    live camera sees): handed the execution while it runs."""

    def attach(self, controls: ExecutionControls) -> None: ...

    def detach(self, controls: ExecutionControls) -> None: ...


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


@dataclass(frozen=True)
class Look:
    """The views read at one node: the last one and, once stable, its reading (else
    why the look ended without one)."""

    view: View | None
    reading: Reading | None
    reason: str
    frames: int
    seconds: float


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
    decided: CameraDecision, value: str, reading: Reading, view: View, look: Look
) -> CameraReading:
    """The evidence of a camera reading: what it decided (a label or a surprise)."""
    return CameraReading(
        decided=decided,
        value=value,
        confidence=round(reading.confidence, 3),
        reason=reading.reason,
        frames=look.frames,
        frame_index=view.frame.index,
        seconds=round(look.seconds, 3),
        placements=placements(view.world),
        outlines=outlines(view.world),
    )


def camera_outcome(
    action: Action | None,
    reading: Reading,
    view: View,
    look: Look,
    truth: str | None,
    picture: bytes,
) -> Outcome:
    """A camera answer with its evidence: the reading, the deciding frame, and (with a
    simulated human) what the human really did, so agreement is counted from the store."""
    assert reading.label is not None
    evidence = Evidence(
        camera=_seen("label", reading.label, reading, view, look),
        truth=None if truth is None else Truth(truth),
        jpeg=picture,
    )
    return Outcome(
        reading.label,
        "camera",
        round(reading.confidence, 3),
        f"{describe(action, reading.label)} (camera: {reading.reason})",
        evidence,
    )


def camera_surprise(reading: Reading, view: View, look: Look, picture: bytes) -> Outcome:
    """What the camera saw that fits no outcome: the executor plans again from it."""
    assert reading.surprise is not None
    seen = _seen("surprise", str(reading.surprise), reading, view, look)
    return Outcome(
        "",
        "camera",
        round(reading.confidence, 3),
        f"camera: {reading.reason}",
        Evidence(camera=seen, jpeg=picture),
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


def _ended(why: str, reading: Reading | None) -> str:
    """Why a look ended before a view decided it; after a stable view that fitted
    nothing, that view's words come first."""
    if reading is None:
        return why
    if reading.label is not None or reading.surprise is not None:
        return reading.reason
    return f"{reading.reason} ({why})"


class CameraSource:
    """Answers sensing nodes from the views of `feed`, after `before` has acted.

    At each node it reads at least `min_frames` fresh views (by default the
    tracker's and the estimate's hysteresis: `settle_frames`), then until the
    estimate is stable; it gives up after `max_frames` views (None: no limit) or
    `timeout_s` seconds, or at once when `interrupt()` is called (an abort).
    `watch`, when given, is handed the execution the source answers for (the walker
    attaches and detaches the source).
    """

    name: AnswerSource = "camera"

    def __init__(
        self,
        feed: ViewFeed,
        before: BeforeLook | None = None,
        *,
        min_frames: int | None = None,
        max_frames: int | None = 120,
        timeout_s: float = 10.0,
        watch: ExecutionWatch | None = None,
    ) -> None:
        self.feed = feed
        self.before = before
        self.watch = watch
        self.min_frames = settle_frames(feed.perception) if min_frames is None else min_frames
        self.max_frames = max_frames
        self.timeout_s = timeout_s
        self.last_observation: CameraObservation | None = None
        self.last_frame_jpeg: bytes | None = None
        self.observations: list[CameraObservation] = []
        self._surprised: set[tuple[str, Surprise]] = set()
        self._interrupted = threading.Event()

    def attach(self, controls: ExecutionControls) -> None:
        if self.watch is not None:
            self.watch.attach(controls)

    def detach(self, controls: ExecutionControls) -> None:
        if self.watch is not None:
            self.watch.detach(controls)

    def interrupt(self) -> None:
        """Ends a look under way, and every later one, without an answer (an abort);
        whoever acts before a look is interrupted too (a click being waited for)."""
        self._interrupted.set()
        if isinstance(self.before, Interruptible):
            self.before.interrupt()

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        action = node.action
        if not is_sensing(action):
            return None
        if self.before is not None and not self.before.before_look(node_id, node, options):
            return None  # nobody said what happens here: the fallback asks
        look = self._look(action, options)
        self._keep(node_id, action, look)
        view, reading = look.view, look.reading
        if view is None or reading is None:
            return None
        if reading.surprise is not None:
            if (node_id, reading.surprise) in self._surprised:
                # Said once per node: if the executor could not follow it, the fallback
                # answers instead of the camera repeating what was already refused.
                return None
            self._surprised.add((node_id, reading.surprise))
            self.last_frame_jpeg = jpeg(view.frame)
            return camera_surprise(reading, view, look, self.last_frame_jpeg)
        if reading.label is None:
            return None
        self.last_frame_jpeg = jpeg(view.frame)
        truth = None if self.before is None else self.before.truth(node_id)
        return camera_outcome(action, reading, view, look, truth, self.last_frame_jpeg)

    def _look(self, action: Action | None, options: Sequence[str]) -> Look:
        """Reads views until a stable one decides the node, or a limit ends the look.

        A stable view decides when it fits an option or shows a surprise. When it
        does neither, it decides too if someone acted before the look (what is seen
        now is what they did); else a person may still be on the way, and the
        camera watches on."""
        start = time.monotonic()  # after the act: the time from the human's move
        self.feed.start_look()
        view: View | None = None
        reading: Reading | None = None
        count = 0
        while True:
            limit = self._limit(count, start)
            if limit is not None:
                reason = _ended(limit, reading)
                break
            got = self.feed.next_view(min(1.0, self.timeout_s - (time.monotonic() - start)))
            if got is None:
                if self.feed.ended is None:
                    continue
                if reading is None and view is not None and view.world.stable:
                    # The last view is all there will be: a stable one says what it shows.
                    reading = outcome_of(action, view.world, options)
                reason = _ended(self.feed.ended, reading)
                break
            view, reading, count = got, None, count + 1
            if count < self.min_frames or not got.world.stable:
                continue
            reading = outcome_of(action, got.world, options)
            decided = reading.label is not None or reading.surprise is not None
            if decided or self.before is not None:
                reason = reading.reason
                break
        return Look(view, reading, reason, count, time.monotonic() - start)

    def _limit(self, count: int, start: float) -> str | None:
        """Why the look ends before a view decides it, if it does."""
        if self._interrupted.is_set():
            return "interrupted"
        if self.max_frames is not None and count >= self.max_frames:
            return f"no stable view that decides within {self.max_frames} frames"
        if time.monotonic() - start > self.timeout_s:
            return f"no stable view that decides within {self.timeout_s:g} s"
        return None

    def _keep(self, node_id: str, action: Action | None, look: Look) -> None:
        reading = look.reading
        obs = CameraObservation(
            node_id,
            None if action is None else str(action),
            None if look.view is None else look.view.world,
            None if reading is None else reading.label,
            look.reason,
            look.frames,
            look.seconds,
        )
        self.last_observation = obs
        self.observations.append(obs)
