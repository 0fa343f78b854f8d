"""The camera's frame at its own size, in a window of one page.

Each page gets its own "Enlarge the frame" box in the Camera panel. Ticking it
opens, on that page only, a floating window holding the annotated frame at the
size it is sent (640 px wide) with each part's placement written beside it;
unticking it closes the window. The docked panels do not move, and no other
page, nor any page that connects later, sees the window or the box ticked:
viser replays what is sent to every page, so a shared box or a shared
placement would have become every later visitor's layout.
"""

from __future__ import annotations

import threading

import numpy as np
import viser

FRAME_PX = (640, 480)  # the frame as the panel sends it (4:3 cameras)
# The window's own margins around its content and its tab bar, measured in
# Chromium (viser 1.1.1): the frame shows whole, at its own size.
SIDE_PX = 26.0
TOP_PX = 56.0
LABEL = "Enlarge the frame"
HINT = "Opens the camera's frame at its own size in a window of this page only."


class FrameWindow:
    """One page's window; `show` puts a frame in it (None: no camera runs)."""

    def __init__(self, client: viser.ClientHandle, frame: np.ndarray | None) -> None:
        self.panel = client.gui.add_panel()
        with self.panel.add_tab("Camera frame"):
            self.note = client.gui.add_markdown(
                "No camera is running: start it in the Camera panel.", visible=frame is None
            )
            first = frame if frame is not None else np.zeros((*FRAME_PX[::-1], 3), np.uint8)
            self.image = client.gui.add_image(
                first, format="jpeg", jpeg_quality=85, visible=frame is not None
            )
        self.size = first.shape[:2]
        h, w = self.size
        # At the bench's top left, next to the left column: the Camera panel's
        # box that closes it stays in sight.
        self.panel.float(x=0, y=0, width=w + SIDE_PX, height=h + TOP_PX)

    def show(self, frame: np.ndarray | None) -> None:
        if frame is None:
            self.image.visible = False
            self.note.visible = True
            return
        if frame.shape[:2] != self.size:  # a camera of another shape: the frame stays whole
            self.size = frame.shape[:2]
            self.panel.set_height(self.size[0] + TOP_PX)
        self.image.image = frame
        if not self.image.visible:
            self.image.visible = True
            self.note.visible = False

    def close(self) -> None:
        self.panel.remove()


class FrameWindows:
    """The Enlarge boxes of the pages connected now, and their open windows.

    `tab` is the Camera panel's container; `order` places each page's box in it.
    `show` is called from the camera's thread, the boxes from viser's."""

    def __init__(self, tab: viser.GuiTabHandle, order: float) -> None:
        self.tab = tab
        self.order = order
        self.frame: np.ndarray | None = None
        self._open: dict[int, FrameWindow] = {}
        self._lock = threading.Lock()

    def greet(self, client: viser.ClientHandle) -> None:
        with self.tab:
            box = client.gui.add_checkbox(LABEL, False, order=self.order, hint=HINT)
        box.on_update(lambda _: self._toggle(client, bool(box.value)))

    def leave(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._open.pop(client.client_id, None)  # its elements went with the page

    def opened(self, client_id: int) -> bool:
        with self._lock:
            return client_id in self._open

    def show(self, frame: np.ndarray | None) -> None:
        with self._lock:
            self.frame = frame
            windows = list(self._open.values())
        for window in windows:
            window.show(frame)

    def _toggle(self, client: viser.ClientHandle, enlarge: bool) -> None:
        with self._lock:
            window = self._open.pop(client.client_id, None)
            if window is not None:
                window.close()
            if enlarge:
                self._open[client.client_id] = FrameWindow(client, self.frame)
