"""The View panel: camera presets for the bench, the plan tree and the selected node.

A page's camera starts on the bench; a plan made in the page (`Planned`) turns
every page's camera to the tree. Where a preset puts the camera is
`camera_pose`, a plain function of where the stage draws the tree. See
stage.py for the panel pattern.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import viser

from app.dashboard.stage import Events, Planned, Stage, TreeFrame

Point = tuple[float, float, float]
Pose = tuple[Point, Point]  # the camera's position, and the point it looks at
CAMERAS: dict[str, Pose] = {
    "Bench": ((2.6, -1.5, 0.9), (0.7, 0.0, -0.2)),
    "Robot view": ((-0.4, 0.0, 0.6), (1.0, 0.0, -0.3)),
    "Human view": ((2.2, 0.0, 0.5), (0.6, 0.0, -0.2)),
    "Top": ((0.85, -0.01, 2.6), (0.85, 0.0, -0.05)),
}
TREE = "Plan tree"
SELECTED = "Selected"
VIEWS = (*CAMERAS, TREE, SELECTED)


def camera_pose(view: str, tree: TreeFrame | None) -> Pose | None:
    """Where `view` puts the camera; None for a view of a tree not drawn yet. The
    whole tree ("Plan tree", also "Selected" with nothing selected) is framed
    from far enough back to fit, the selected node from close by."""
    if view in CAMERAS:
        return CAMERAS[view]
    if tree is None:
        return None
    if view == SELECTED and tree.selected is not None:
        x, y, z = tree.selected
        return (x - 1.2, y, z), (x, y, z)
    (y, z), (width, height) = tree.middle, tree.size
    distance = max(2.0, 0.9 * max(width, height * 1.6))
    return (tree.wall_x - distance, y, z), (tree.wall_x, y, z)


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
        events.subscribe(Planned, lambda _: self.aim(TREE))

    def greet(self, client: viser.ClientHandle) -> None:
        """A page that connects looks at the bench."""
        self.aim("Bench", client)

    def aim(self, view: str, client: viser.ClientHandle | None = None) -> None:
        """Turn `client`'s camera (every page's: None) to `view`."""
        pose = camera_pose(view, self.stage.tree_frame())
        if pose is None:
            return
        position, target = pose
        for c in [client] if client is not None else list(self.clients()):
            with c.atomic():
                c.camera.position = position
                c.camera.look_at = target

    def close(self) -> None:
        """Nothing runs in the panel's own threads."""
