"""Where the dashboard's panels stand: four docked panels around the bench.

Left, the main panel (the guide, then what a user does in order: scenario,
plan, view, speech) above the camera panel; right, the plan tree (tabs: the
tree, the selected node) above the execution panel (tabs: the execution's
controls, the simulated human, the timeline and the log; the review of
stored sessions). The bench's 3D view fills the
middle. Every panel can be minimised, dragged out to float, or docked
elsewhere by the user; the camera panel's "Enlarge" floats it at the
frame's own size.

Widths are chosen for 1600×1000 and still leave the bench 460 px at
1280×800 (measured in headless Chromium, see the README's screenshots).
"""

from __future__ import annotations

from typing import Any

import viser

LEFT_PX = 320.0
RIGHT_PX = 500.0
CAMERA_FLOAT_PX = 680.0  # the camera's 640 px frame, with the panel's margins

GUIDE = (
    "**Tandem** plans what a robot and a human do to build a table. "
    "**1. Plan** the scenario (below), **2. Execute** the plan (right), "
    "**3. Answer** for the human with the buttons there, or let the camera and "
    "the voice answer. The tree (right) shows the plan; click a node to see the "
    "bench as that node leaves it."
)


class Layout:
    """The panels and their tabs; `with layout.tree_tab:` builds into one."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui = gui
        main = gui.main_panel
        main.dock_left()
        main.set_width(LEFT_PX)
        self.tree_panel = gui.add_panel()
        self.tree_tab: Any = self.tree_panel.add_tab("Plan tree")
        self.node_tab: Any = self.tree_panel.add_tab("Selected node")
        self.tree_panel.dock_right()
        self.tree_panel.set_width(RIGHT_PX)
        self.execution_panel = gui.add_panel()
        self.execution_tab: Any = self.execution_panel.add_tab("Execution")
        self.review_tab: Any = self.execution_panel.add_tab("Review")
        self.execution_panel.dock_below(self.tree_panel)
        self.camera_panel = gui.add_panel()
        self.camera_tab: Any = self.camera_panel.add_tab("Camera")
        self.camera_panel.dock_below(gui.main_panel)
        self.camera_floating = False

    def enlarge_camera(self, enlarge: bool) -> None:
        """Float the camera panel at the frame's size, or dock it back."""
        self.camera_floating = enlarge
        if enlarge:
            self.camera_panel.float(x=-20, y=20, width=CAMERA_FLOAT_PX, height=620)
        else:
            self.camera_panel.dock_below(self.gui.main_panel)
