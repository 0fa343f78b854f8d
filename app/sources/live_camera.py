"""A camera that keeps watching: one thread reads frames and runs perception, and
the latest view serves a live display and the answers of an execution.

`LiveCamera` owns a frame source (a real camera, a file, a folder, or the
simulated camera) and its `BenchPerception`; views reach `on_view` as they come.
`LiveCameraSource` answers an execution's sensing nodes from the views that
follow the moment a node is asked (or, with the simulated camera, the moment the
simulated human acted out what a click chose): the camera, not the click, says
which branch is taken. `for_execution` wires both for one run of a plan.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from app.execution.events import ExecutionEvent, Node, Outcome, OutcomeSource
from app.sim.human import SimulatedHuman, SimulatedWorld, StillSimulatedCamera
from app.sources.bench_layout import bench_layout
from app.sources.camera import camera_outcome, is_sensing, jpeg, outcome_of
from perception.frames import Frame, FrameSource
from perception.intrinsics import CameraIntrinsics
from perception.pipeline import BenchPerception, Perceived
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.scenario.model import Scenario

Vec3 = tuple[float, float, float]
Listener = Callable[[ExecutionEvent], None]


@dataclass(frozen=True)
class LiveView:
    """One processed frame."""

    seq: int  # views processed so far, this one included
    frame: Frame
    perceived: Perceived
    seconds: float  # perception's time on this frame (decode, locate, track, estimate)
    fps: float  # frames processed per second, over the last second or so
    at: float  # time.monotonic() when it was ready


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
        simulated: StillSimulatedCamera | None = None,
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
                with self._lock:
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
                view = LiveView(seq, frame, perceived, seconds, fps, now)
                with self._cond:
                    self._latest = view
                    self._cond.notify_all()
                if self.on_view is not None:
                    self.on_view(view)
                if period:
                    next_at = max(next_at + period, time.monotonic() - period)
                    self._stop.wait(max(0.0, next_at - time.monotonic()))
        except Exception as err:  # a camera unplugged mid-run: say so, never crash the page
            self.ended = f"the camera failed: {err}"
        finally:
            with self._cond:
                self._cond.notify_all()

    def for_execution(
        self, plan: Plan, intent: OutcomeSource
    ) -> tuple[OutcomeSource, list[Listener]]:
        """The camera's answers for one run of `plan`, and the listeners to add. With
        the simulated camera the bench is reset and a simulated human acts out, at
        each sensing node, what `intent` (the clicks) chooses."""
        if self.simulated is None:
            return LiveCameraSource(self), []
        world = SimulatedWorld(part_boxes(self.scenario), self.layout, self)
        human = SimulatedHuman(plan, world)
        return LiveCameraSource(self, human, intent), [human.on_event]


class LiveCameraSource:
    """Answers sensing nodes from the live views that follow the question.

    It reads at least `settle_frames` new views (the tracker's and the estimate's
    hysteresis), then takes the first stable estimate that fits an option (a
    simulated run takes the first stable one: the human has already acted), and
    gives up after `timeout_s`.
    """

    name = "camera"

    def __init__(
        self,
        live: LiveCamera,
        human: SimulatedHuman | None = None,
        intent: OutcomeSource | None = None,
        *,
        settle_frames: int | None = None,
        timeout_s: float = 15.0,
    ) -> None:
        self.live = live
        self.human = human
        self.intent = intent
        perception = live.perception
        if settle_frames is None:
            settle_frames = (
                perception.tracker.settings.confirm_frames
                + perception.estimator.settings.hysteresis_frames
                + perception.estimator.settings.stable_frames
            )
        self.settle_frames = settle_frames
        self.timeout_s = timeout_s
        self._interrupted = threading.Event()
        self.answer_seconds: list[float] = []  # from the human's act to the answer

    def interrupt(self) -> None:
        self._interrupted.set()

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        action = node.action
        if not is_sensing(action):
            return None
        wanted: Outcome | None = None
        if self.human is not None:
            if self.intent is not None:
                wanted = self.intent.choose(node_id, node, options)
                if wanted is None:
                    return None  # no click (an abort): the fallback asks
        # From before the human acts (its move is part of the time), after any click.
        start = time.monotonic()
        if self.human is not None:
            # Without an intent the simulated human makes its own (seeded) choice.
            self.human.act(node_id, node, options, None if wanted is None else wanted.label)
        latest = self.live.latest()
        seq = 0 if latest is None else latest.seq
        count = 0
        while not self._interrupted.is_set() and time.monotonic() - start < self.timeout_s:
            view = self.live.wait_view(seq, 1.0)
            if view is None:
                if self.live.ended is not None or not self.live.running:
                    return None  # the frames ended or the camera was stopped
                continue
            seq, count = view.seq, count + 1
            world = view.perceived.world
            if count < self.settle_frames or not world.stable:
                continue
            reading = outcome_of(action, world, options)
            if reading.label is None:
                if self.human is not None:
                    return None  # the human has acted: what is seen is the answer, or none
                continue  # a person may still be on the way: keep watching
            seconds = time.monotonic() - start
            self.answer_seconds.append(seconds)
            truth = None if self.human is None else self.human.did.get(node_id)
            return camera_outcome(
                action, reading, world, view.frame, count, seconds, truth, jpeg(view.frame)
            )
        return None
