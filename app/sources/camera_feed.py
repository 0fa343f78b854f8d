"""Where the camera source's views come from: frames it pulls, or a live camera's.

A `View` is one processed frame: the frame and perception's world estimate after
it. A `ViewFeed` gives the views that follow the start of a look, and the camera
source (app/sources/camera.py) decides from them the same way whichever feed it
has: `PulledFeed` reads a frame source through `BenchPerception` when asked
(`tandem execute --responses camera:...`, as fast as frames come), and
`app.sources.live_camera.LiveFeed` waits for the views of a camera that keeps
watching in its own thread (the dashboard's Live camera).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from perception.frames import Frame, FrameSource
from perception.pipeline import BenchPerception
from perception.world import WorldEstimate


@dataclass(frozen=True)
class View:
    """One processed frame: what the camera saw and what perception made of it."""

    frame: Frame
    world: WorldEstimate


class ViewFeed(Protocol):
    """The views a camera source looks at."""

    @property
    def perception(self) -> BenchPerception:
        """The perception that makes the views (its settings say how many views a
        change takes to pass the tracker's and the estimate's hysteresis)."""
        ...

    @property
    def ended(self) -> str | None:
        """Why no view will come any more, once so (the frames ended, the camera
        was stopped); None while views may come."""
        ...

    def start_look(self) -> None:
        """A look starts: only the views from now on count."""
        ...

    def next_view(self, timeout: float) -> View | None:
        """The next view, or None if none came within about `timeout` seconds (or
        none will: see `ended`)."""
        ...


def settle_frames(perception: BenchPerception) -> int:
    """Fresh views before a stable estimate may answer: a change made just before
    (by the human or the robot) has then passed the tracker's and the estimate's
    hysteresis, and the estimate has been stable for its own count."""
    estimator = perception.estimator.settings
    return (
        perception.tracker.settings.confirm_frames
        + estimator.hysteresis_frames
        + estimator.stable_frames
    )


class PulledFeed:
    """Views read on demand from `frames` through `perception`; `record`, when a list,
    collects every frame read (to write a video of the run)."""

    def __init__(
        self,
        frames: FrameSource,
        perception: BenchPerception,
        record: list[Frame] | None = None,
    ) -> None:
        self.frames = frames
        self.perception = perception
        self.record = record
        self.ended: str | None = None

    def start_look(self) -> None:
        """Nothing to skip: the next frame read is taken after the look starts."""

    def next_view(self, timeout: float) -> View | None:
        # A read waits as long as the source does (a file: not at all).
        frame = self.frames.read()
        if frame is None:
            self.ended = "the frames ended"
            return None
        if self.record is not None:
            self.record.append(frame)
        return View(frame, self.perception.process(frame).world)
