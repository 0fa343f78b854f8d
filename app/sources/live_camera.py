"""A camera that keeps watching: one thread reads frames and runs perception, and
the latest view serves a live display and the answers of an execution.

`LiveCamera` owns a frame source (a real camera, a file, a folder, or the
simulated camera) and its `BenchPerception`; views reach `on_view` as they come.
`LiveFeed` gives an execution's camera source (app/sources/camera.py) the views
that follow the moment a node is asked (or, with the simulated camera, the
moment the simulated human acted out what a click chose): the camera, not the
click, says which branch is taken, and a surprise it sees reaches the executor
as in a headless run. `live_source` makes that source.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from app.sources.bench_layout import bench_layout
from app.sources.camera import BeforeLook, CameraSource, ExecutionWatch
from app.sources.camera_feed import View
from perception.frames import Frame, FrameSource
from perception.intrinsics import CameraIntrinsics
from perception.pipeline import BenchPerception, Perceived
from planner.scenario.model import Scenario

Vec3 = tuple[float, float, float]
# A person at a live camera acts in their own time: a look waits this long for a
# view that fits (a simulated human has acted before the look: the first stable view).
LIVE_TIMEOUT_S = 15.0


class SimulatedBench(Protocol):
    """The scene of a simulated camera, whose parts a simulated world moves and
    redraws (the simulated camera's frames, app.sim)."""

    def move(self, part_id: str, position: Vec3, yaw: float | None = None) -> None: ...

    def reshape(self, part_id: str, profile: str) -> None: ...


@dataclass(frozen=True)
class LiveView:
    """One processed frame."""

    seq: int  # views processed so far, this one included
    frame: Frame
    perceived: Perceived
    seconds: float  # perception's time on this frame (decode, locate, track, estimate)
    fps: float  # frames processed per second, over the last second or so
    at: float  # time.monotonic() when it was ready
    # When the frame was taken, on the wall clock (epoch seconds): just before the read
    # that returned it. A camera's read waits for its next frame and the simulated
    # camera draws the bench as it is then, so the picture shows that moment (a
    # real camera's exposure is up to a frame's interval before).
    captured: float = 0.0


class LiveCamera:
    """Reads `frames` in a thread, paced to `pace_fps` for sources that are not live
    (a file, a folder, the simulated camera), and keeps the latest view."""

    def __init__(
        self,
        frames: FrameSource,
        intrinsics: CameraIntrinsics,
        scenario: Scenario,
        *,
        name: str,
        simulated: SimulatedBench | None = None,
        pace_fps: float | None = 30.0,
        on_view: Callable[[LiveView], None] | None = None,
    ) -> None:
        self.frames = frames
        self.intrinsics = intrinsics
        self.scenario = scenario
        self.layout = bench_layout(scenario)
        self.name = name
        self.simulated = simulated
        self.pace_fps = pace_fps
        self.on_view = on_view
        # Whoever else follows every view (a watch of the human's actions), in this thread.
        self.watchers: list[Callable[[LiveView], None]] = []
        self.perception = BenchPerception(intrinsics, self.layout)
        self.ended: str | None = None  # why the frames stopped, once they have
        self._lock = threading.Lock()  # the frame source: read here, moved by the executor
        self._cond = threading.Condition()
        self._latest: LiveView | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="live-camera", daemon=True)

    def start(self) -> LiveCamera:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(5.0)
        with self._lock:
            self.frames.close()
        with self._cond:
            self._cond.notify_all()

    @property
    def running(self) -> bool:
        return self._thread.is_alive() and not self._stop.is_set()

    def latest(self) -> LiveView | None:
        with self._cond:
            return self._latest

    def wait_view(self, after_seq: int, timeout: float) -> LiveView | None:
        """The first view after `after_seq`, or None if none comes within `timeout`."""
        with self._cond:
            self._cond.wait_for(
                lambda: (
                    (self._latest is not None and self._latest.seq > after_seq)
                    or self._stop.is_set()
                    or self.ended is not None
                ),
                timeout,
            )
            view = self._latest
        return view if view is not None and view.seq > after_seq else None

    def move(self, part_id: str, position: Vec3, yaw: float | None = None) -> None:
        """Moves a part of the simulated bench (a `PartMover` for `SimulatedWorld`)."""
        if self.simulated is None:
            raise RuntimeError("only the simulated camera's parts can be moved")
        with self._lock:
            self.simulated.move(part_id, position, yaw)

    def reshape(self, part_id: str, profile: str) -> None:
        """Redraws a part of the simulated bench with another outline."""
        if self.simulated is None:
            raise RuntimeError("only the simulated camera's parts can be reshaped")
        with self._lock:
            self.simulated.reshape(part_id, profile)

    def _run(self) -> None:
        seq = 0
        stamps: list[float] = []
        period = 1.0 / self.pace_fps if self.pace_fps else 0.0
        next_at = time.monotonic()
        try:
            while not self._stop.is_set():
                # Only the read holds the scene: a simulated part moved meanwhile is
                # drawn in the next frame, not held up by perception's time.
                with self._lock:
                    captured = time.time()
                    frame = self.frames.read()
                if frame is None:
                    self.ended = "the frames ended"
                    break
                start = time.perf_counter()
                perceived = self.perception.process(frame)
                seconds = time.perf_counter() - start
                now = time.monotonic()
                stamps = [t for t in stamps if now - t < 1.0] + [now]
                seq += 1
                fps = (len(stamps) - 1) / (stamps[-1] - stamps[0]) if len(stamps) > 1 else 0.0
                view = LiveView(seq, frame, perceived, seconds, fps, now, captured)
                with self._cond:
                    self._latest = view
                    self._cond.notify_all()
                if self.on_view is not None:
                    self.on_view(view)
                for watcher in list(self.watchers):
                    watcher(view)
                if period:
                    next_at = max(next_at + period, time.monotonic() - period)
                    self._stop.wait(max(0.0, next_at - time.monotonic()))
        except Exception as err:  # a camera unplugged mid-run: say so, never crash the page
            self.ended = f"the camera failed: {err}"
        finally:
            with self._cond:
                self._cond.notify_all()


class LiveFeed:
    """The views of a running `LiveCamera` that come after a look starts (a `ViewFeed`)."""

    def __init__(self, live: LiveCamera) -> None:
        self.live = live
        self._seq = 0

    @property
    def perception(self) -> BenchPerception:
        return self.live.perception

    @property
    def ended(self) -> str | None:
        if self.live.ended is not None:
            return self.live.ended
        return None if self.live.running else "the camera was stopped"

    def start_look(self) -> None:
        latest = self.live.latest()
        self._seq = 0 if latest is None else latest.seq

    def next_view(self, timeout: float) -> View | None:
        view = self.live.wait_view(self._seq, timeout)
        if view is None:
            return None
        self._seq = view.seq
        return View(view.frame, view.perceived.world)


def live_source(
    live: LiveCamera, before: BeforeLook | None = None, watch: ExecutionWatch | None = None
) -> CameraSource:
    """The camera source of one execution on `live`; `before` acts at each sensing
    node before the camera looks (a simulated human acting out a click); `watch` is
    handed the execution (app.sources.camera_human keeps the human's actions seen)."""
    return CameraSource(
        LiveFeed(live), before, max_frames=None, timeout_s=LIVE_TIMEOUT_S, watch=watch
    )
