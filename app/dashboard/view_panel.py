"""The View panel: camera presets for the bench (the tree has its own panel).

A page's camera starts on the bench. See stage.py for the panel pattern.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import viser

from app.dashboard.stage import Events, Stage

Point = tuple[float, float, float]
Pose = tuple[Point, Point]  # the camera's position, and the point it looks at
CAMERAS: dict[str, Pose] = {
    # Robot, bench and human in the middle of the page, between the side panels.
    "Bench": ((2.75, -1.85, 1.05), (0.95, 0.0, -0.2)),
    # Just above and in front of Baxter's head screen, looking down the bench.
    "Robot view": ((0.3, 0.0, 0.95), (1.1, 0.0, -0.2)),
    # Above the human's head (at x 1.85, z 0.54), looking over the bench.
    "Human view": ((2.3, 0.35, 1.25), (0.7, 0.0, -0.15)),
    "Top": ((0.85, -0.01, 2.6), (0.85, 0.0, -0.05)),
}
VIEWS = tuple(CAMERAS)


class ViewPanel:
    """`clients`: the pages connected now, whose cameras a preset may turn."""

    def __init__(
        self,
        gui: viser.GuiApi,
        stage: Stage,
        events: Events,
        clients: Callable[[], Iterable[viser.ClientHandle]],
    ) -> None:
        self.stage = stage
        self.clients = clients
        with gui.add_folder("View"):
            views = gui.add_button_group("Camera", VIEWS)
            views.on_click(lambda event: self.aim(event.target.value, event.client))

    def greet(self, client: viser.ClientHandle) -> None:
        """A page that connects looks at the bench."""
        self.aim("Bench", client)

    def aim(self, view: str, client: viser.ClientHandle | None = None) -> None:
        """Turn `client`'s camera (every page's: None) to `view`."""
        if view not in CAMERAS:
            return
        position, target = CAMERAS[view]
        for c in [client] if client is not None else list(self.clients()):
            with c.atomic():
                c.camera.position = position
                c.camera.look_at = target

    def close(self) -> None:
        """Nothing runs in the panel's own threads."""
