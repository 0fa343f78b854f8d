"""Where the dashboard's panels stand: four docked panels around the bench.

Left, the main panel (the guide, then plan, scenario, view, speech: the Plan
button where a new page shows it) above the camera panel; right, the plan tree (the tree,
and the selected node's details right under it, in one tab) above the
execution panel (tabs: the execution's controls, the simulated human, the
timeline and the log; the review of stored sessions). The bench's 3D view
fills the middle. Every panel can be minimised, dragged out to float, or
docked elsewhere by the user; "Wide" (the tree's View buttons) widens a
page's right column over the bench, leaving the bench `BENCH_LEFT_PX`.

The layout is each page's own. viser keeps a placement command sent to every
page and replays it to every page that connects later, so one page's
rearrangement sent that way would become every later visitor's layout: the
shared layout is placed once, when the server starts, and everything after
that (restoring the layout, the camera's enlarged frame) goes to the one page
that asked.

Widths are chosen for 1600×1000 and still leave the bench 452 px at
1280×800 (measured in headless Chromium, see the screenshots in docs/dashboard.md).
"""

from __future__ import annotations

from typing import Literal

import viser
from viser._gui_handles import CONTROL_PANEL_ID, _PlacementMixin

from app.dashboard.operator import Click

LEFT_PX = 320.0
RIGHT_PX = 500.0
BENCH_LEFT_PX = 360.0  # the bench's width beside a wide tree

GUIDE = (
    "**Tandem** plans what a robot and a human do to build a table. **1. Plan** "
    "(below; pick or edit the scenario under it), **2. Execute** (right), **3. Answer** "
    "for the human there, or let the camera and the voice answer. Click a node of "
    "the tree to see the bench as it leaves it."
)


class Placement(_PlacementMixin):
    """viser's placement commands for the panel `uuid`, sent through `gui`: the
    server's (every page, replayed to later ones) or one page's (`client.gui`)."""

    def __init__(self, uuid: str, gui: viser.GuiApi) -> None:
        self._placement_uuid = uuid
        self._placement_gui_api = gui

    def split(self, anchor: str, side: Literal["above", "below"]) -> None:
        """Stack this panel against the docked panel `anchor` (in any scope: the
        panels are the server's, a page's command only places them there)."""
        self._set_position({"kind": "split", "anchor_uuid": anchor, "side": side})


class Layout:
    """The panels and their tabs; `with layout.tree_tab:` builds into one."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui = gui
        self.tree_panel = gui.add_panel()
        self.tree_tab: viser.GuiTabHandle = self.tree_panel.add_tab("Plan tree")
        self.execution_panel = gui.add_panel()
        self.execution_tab: viser.GuiTabHandle = self.execution_panel.add_tab("Execution")
        self.review_tab: viser.GuiTabHandle = self.execution_panel.add_tab("Review")
        self.camera_panel = gui.add_panel()
        self.camera_tab: viser.GuiTabHandle = self.camera_panel.add_tab("Camera")
        self._right_px: dict[int, float] = {}  # a page's right column, once widened
        self._arrange(gui)

    def restore(self, client: viser.ClientHandle) -> None:
        """Put `client`'s panels back where a new page has them, at their widths
        (after the user dragged, floated, docked or merged them); other pages keep
        theirs."""
        self._right_px.pop(client.client_id, None)
        self._arrange(client.gui)

    def widen_tree(self, client: viser.ClientHandle, wide: bool) -> None:
        """Widen `client`'s right column (the tree, the execution) over the bench,
        leaving the bench `BENCH_LEFT_PX`, or give it back its width; only that
        page's."""
        px = RIGHT_PX
        if wide:
            bench = float(client.camera.image_width)  # the 3D view's width on that page
            right = self._right_px.get(client.client_id, RIGHT_PX)
            px = max(RIGHT_PX, right + bench - BENCH_LEFT_PX)
        self._right_px[client.client_id] = px
        for panel in (self.tree_panel, self.execution_panel):
            Placement(panel._placement_uuid, client.gui).set_width(px)

    def _arrange(self, gui: viser.GuiApi) -> None:
        tree_id = self.tree_panel._placement_uuid  # viser names a panel only there
        main = Placement(CONTROL_PANEL_ID, gui)
        tree = Placement(tree_id, gui)
        execution = Placement(self.execution_panel._placement_uuid, gui)
        camera = Placement(self.camera_panel._placement_uuid, gui)
        main.dock_left()
        tree.dock_right()
        execution.split(tree_id, "below")
        camera.split(CONTROL_PANEL_ID, "below")
        # Every panel's width, not only the columns' first: a docked column is as
        # wide as what its panels last asked for.
        for placement, px in ((main, LEFT_PX), (camera, LEFT_PX), (tree, RIGHT_PX),
                              (execution, RIGHT_PX)):  # fmt: skip
            placement.set_width(px)

    def add_restore_button(self, gui: viser.GuiApi) -> None:
        """A button that restores the layout of the page it is clicked on."""
        button = gui.add_button(
            "Restore the layout", hint="Puts this page's panels back where they started."
        )

        def restore(event: Click) -> None:
            if event.client is not None:
                self.restore(event.client)

        button.on_click(restore)
