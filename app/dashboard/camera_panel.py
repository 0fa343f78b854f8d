"""The Live camera panel: pick a source, watch what perception makes of it, let it answer.

A source (the simulated camera, a webcam, a video file or an image folder) runs
in a `LiveCamera`; the panel shows its latest frame with each decoded code boxed
and labelled and the bench axes drawn, the frame rate and perception's time per
frame, and per part what the tracker believes. While a camera runs it is
announced on `Events` (`CameraChanged`) as `LiveAnswers`, so executions take
their sensing answers from it, surprises included (with the simulated camera,
a simulated human first acts out each click); a camera that cannot be opened
is said in one line and the clicks keep answering. See stage.py for the panel
pattern.

The docked panel is a column's width (~300 px): its frame names each part in
letters big enough to read there, and the words of what is believed of it are
listed below. "Enlarge" is each page's own: it opens, on that page only, a
window with the frame at its own size and the long labels, without moving the
docked panels (frame_window.py).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import viser

from app.dashboard.frame_window import FrameWindows
from app.dashboard.operator import Operator
from app.dashboard.scenario_folders import RefusedName, find_recording
from app.dashboard.stage import CameraChanged, CameraSeen, Events, ScenarioChanged, Stage
from app.responses.camera import HumanFactory, LiveAnswers, open_camera
from app.sim.camera import StillSimulatedCamera
from app.sim.human import SimulatedHuman
from app.sources.camera_reading import belief_words
from app.sources.live_camera import LiveCamera, LiveView
from perception.annotate import annotate
from perception.decode import Detection
from perception.frames import SourceError
from perception.markers import PartCode

SOURCES = ("simulated", "webcam", "video file", "image folder")
VIEW_WIDTH = 640  # px sent to the page: the frame's own width
DOCKED_TEXT = 2.4  # the docked frame shows at ~300 px: its words drawn 2.4 times larger
SHOW_EVERY_S = 0.2  # the page's view refreshes five times a second at most


def source_spec(kind: str, where: str) -> str:
    """The SOURCE spec of app.sources.camera_input for a choice in the panel."""
    if kind == "simulated":
        return "sim"
    if kind == "webcam":
        return f"webcam:{where.strip() or '0'}"
    return where.strip()


class CameraPanel:
    """`recordings`: the only folder whose videos and image folders a page may name.

    `simulated_human` makes, for each execution with the simulated camera, the
    simulated human who acts out the clicks before the camera looks.
    """

    def __init__(
        self,
        gui: viser.GuiApi,
        stage: Stage,
        events: Events,
        operator: Operator,
        recordings: Path,
        tab: viser.GuiTabHandle,
    ) -> None:
        """`tab`: the panel's container, where each page gets its own Enlarge box."""
        self.recordings = recordings
        self.stage = stage
        self.events = events
        self.live: LiveCamera | None = None
        self.simulated_human: HumanFactory = SimulatedHuman
        self.last_annotated: np.ndarray | None = None
        self._shown_at = 0.0
        self._lock = threading.Lock()
        self.kind: viser.GuiDropdownHandle[str] = gui.add_dropdown(
            "Source", SOURCES, initial_value="simulated"
        )
        self.where: viser.GuiTextHandle = gui.add_text("Webcam index, or name in recordings", "0")
        # Stop, then start again, to switch sources.
        # During an execution only its operator may change what answers it.
        self.start_button = gui.add_button("Start camera")
        self.start_button.on_click(operator.only("start the camera", lambda _: self.start()))
        self.stop_button = gui.add_button("Stop camera", disabled=True)
        self.stop_button.on_click(
            operator.only(
                "stop the camera", lambda _: self.stop("Camera stopped: clicks answer.")
            )
        )
        self.windows = FrameWindows(tab, order=self.stop_button.order + 0.5)
        # The frame first, where the panel opens; what the camera is doing below it.
        self.view = gui.add_image(
            np.zeros((VIEW_WIDTH * 3 // 4, VIEW_WIDTH, 3), np.uint8), format="jpeg",
            jpeg_quality=80, visible=False,
        )  # fmt: skip
        self.status = gui.add_markdown("No camera: clicks answer.")
        self.rate = gui.add_markdown("")
        self.beliefs = gui.add_markdown("")
        events.subscribe(ScenarioChanged, self._scenario_changed)

    def _scenario_changed(self, _: ScenarioChanged) -> None:
        # Another scenario has other parts and another bench: the running camera's
        # layout no longer fits it.
        if self.live is not None:
            self.stop("Scenario changed: start the camera again.")

    def start(self) -> None:
        scenario = self.stage.current_scenario()
        if scenario is None:
            self.status.content = "No scenario loaded."
            return
        self.stop(None)
        spec = source_spec(str(self.kind.value), str(self.where.value))
        try:
            if str(self.kind.value) not in ("simulated", "webcam"):
                spec = str(find_recording(self.recordings, spec))
            camera = open_camera(spec, scenario)
        except RefusedName as err:
            self.status.content = f"**Refused:** {err}; clicks answer."
            return
        except SourceError as err:
            self.status.content = f"**Camera missing:** {err}; clicks answer."
            self.events.publish(CameraChanged(None))
            return
        simulated = camera.frames if isinstance(camera.frames, StillSimulatedCamera) else None
        live = LiveCamera(
            camera.frames, camera.intrinsics, scenario, name=spec, simulated=simulated,
            pace_fps=None if spec.startswith("webcam") else 30.0, on_view=self._viewed,
        )  # fmt: skip
        with self._lock:
            self.live = live
        live.start()
        self.stop_button.disabled = False
        self.start_button.disabled = True
        self.rate.content = "**Waiting for the camera…** (first frame)"
        self.status.content = (
            f"Camera **{spec}** ({camera.origin} intrinsics): it answers the sensing nodes."
        )
        self.events.publish(CameraChanged(LiveAnswers(live, self.simulated_human)))

    def stop(self, why: str | None) -> None:
        with self._lock:
            live, self.live = self.live, None
        if live is None:
            return
        live.stop()
        self.stop_button.disabled = True
        self.start_button.disabled = False
        # No stale picture: a stopped camera shows nothing.
        self.view.visible = False
        self.windows.show(None)
        self.rate.content = self.beliefs.content = ""
        self.last_annotated = None
        if why is not None:
            self.status.content = why
        self.events.publish(CameraChanged(None))

    def _viewed(self, view: LiveView) -> None:
        """Each view (the camera's thread); the page is refreshed a few times a second."""
        now = time.monotonic()
        if now - self._shown_at < SHOW_EVERY_S:
            return
        self._shown_at = now
        live = self.live
        if live is None:
            return
        observation, world = view.perceived.observation, view.perceived.world
        labels = {pid: f"{pid}: {belief_words(p)}" for pid, p in world.parts.items()}
        x0 = live.layout.bench_x[0]

        def drawn(words: dict[str, str] | None, text_scale: float) -> np.ndarray:
            annotated = annotate(
                view.frame.image, observation.detections, observation.camera,
                live.intrinsics, axes_origin=(x0, 0.0, live.layout.bench_top_z),
                labels=words, text_scale=text_scale,
            )  # fmt: skip
            return annotated

        # The frame at its own size, with each part's placement (enlarged windows)...
        self.last_annotated = annotated = drawn(labels, 1.0)
        self.windows.show(rgb_at_view_width(annotated))
        # ...and docked, with only the parts' names, drawn to be read at ~300 px.
        self.view.image = rgb_at_view_width(drawn(None, DOCKED_TEXT))
        if not self.view.visible:
            self.view.visible = True
        located = (
            "located"
            if observation.camera_fresh
            else ("pose kept from an earlier frame" if observation.camera else "not located")
        )
        self.rate.content = (
            f"{view.fps:.0f} fps, latency {view.seconds * 1e3:.1f} ms (frame in, estimate out), "
            f"{len(observation.detections)} codes; camera {located}"
        )
        self.beliefs.content = "\n\n".join(
            f"`{pid}` {belief_words(p)} ({p.confidence:.2f})"
            for pid, p in world.parts.items()
        ) + ("" if world.stable else "\n\n*(settling)*")
        self.events.publish(CameraSeen(*markers_seen(observation.detections, self.stage),
                                       not world.stable))  # fmt: skip
        if live.ended is not None:
            self.status.content = f"Camera **{live.name}**: {live.ended}."

    def close(self) -> None:
        self.stop(None)


def markers_seen(detections: Sequence[Detection], stage: Stage) -> tuple[int, int]:
    """The parts whose codes a frame shows, and how many parts the bench has (each
    carries its code)."""
    seen = {d.code.part_id for d in detections if isinstance(d.code, PartCode)}
    scenario = stage.current_scenario()
    return len(seen), len(scenario.parts) if scenario is not None else 0


def rgb_at_view_width(annotated: np.ndarray) -> np.ndarray:
    """An annotated (BGR) frame as the page gets it: RGB, `VIEW_WIDTH` wide."""
    h, w = annotated.shape[:2]
    small = cv2.resize(annotated, (VIEW_WIDTH, round(h * VIEW_WIDTH / w)),
                       interpolation=cv2.INTER_AREA)  # fmt: skip
    rgb: np.ndarray = cv2.cvtColor(small, cv2.COLOR_BGR2RGB)
    return rgb
