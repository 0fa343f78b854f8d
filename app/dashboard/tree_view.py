"""The plan tree drawn in the 3D scene on a wall, with clickable nodes.

Plotly clicks never reach a viser server, but clicks on scene nodes do, so the
tree is made of boxes (nodes), line segments (edges) and labels, on a vertical
wall behind the viewer of the bench (x = WALL_X, facing the bench). The "Plan tree"
camera looks straight at it; orbit controls give zoom and pan.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app.dashboard.tree_layout import SpanningTree, TreeLayout, layout
from planner.plan.model import KIND_COLOURS, Plan
from planner.vocabulary import Action

WALL_X = 8.0
SCALE = 0.25  # metres per layout unit
TOP_Z = 2.0  # the root's height on the wall
# More visible nodes than this: labels only on the expected branch and around the
# selection, since screen-sized labels of neighbouring columns would overlap.
LABEL_LIMIT = 40
PREFIX = "/tree"
OPEN_COLOUR = (235, 235, 235)
SELECTED = (220, 30, 160)


def rgb(hex_colour: str) -> tuple[int, int, int]:
    h = hex_colour.lstrip("#")
    return (int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16))


def short(action: Action | None, kind: str) -> str:
    if action is None:
        return "goal" if kind == "goal" else "..."
    return str(action).replace("sense(", "sense ").replace("humanHolding", "hHolding")


class TreeView:
    """Draws a plan (or the part planned so far); `on_select(node_id)` on clicks."""

    def __init__(self, server: viser.ViserServer, on_select: Callable[[str], None]) -> None:
        self.server = server
        self.on_select = on_select
        self.plan: Plan | None = None
        self.tree: SpanningTree | None = None
        self.collapsed: set[str] = set()
        self.current: TreeLayout | None = None
        self._handles: list[viser.SceneNodeHandle] = []
        self._highlight: viser.BoxHandle | None = None
        self._near_selection: list[viser.SceneNodeHandle] = []
        self.labelled_all = True
        # Planning, execution and clicks redraw from different threads.
        self._lock = threading.RLock()

    # -- geometry ---------------------------------------------------------------

    def world(self, node_id: str) -> tuple[float, float, float]:
        assert self.current is not None
        lx, ly = self.current.positions[node_id]
        return (WALL_X, -lx * SCALE, TOP_Z - ly * SCALE)

    def centre(self) -> tuple[float, float, float, float]:
        """(y, z) of the middle of the drawn tree, and its width and height in metres."""
        assert self.current is not None
        pts = [self.world(n) for n in self.current.positions]
        ys = [p[1] for p in pts]
        zs = [p[2] for p in pts]
        return (
            (max(ys) + min(ys)) / 2,
            (max(zs) + min(zs)) / 2,
            max(ys) - min(ys),
            max(zs) - min(zs),
        )

    # -- drawing ----------------------------------------------------------------

    def show(self, plan: Plan, *, keep_collapsed: bool = False) -> None:
        """Draw `plan`; a new plan gets the default collapsing (expected branch open)."""
        self.plan = plan
        self.tree = SpanningTree.of(plan)
        if not keep_collapsed:
            self.collapsed = self.tree.default_collapsed(plan)
        self.redraw()

    def toggle(self, node_id: str) -> None:
        if node_id in self.collapsed:
            self.collapsed.discard(node_id)
        else:
            self.collapsed.add(node_id)
        self.redraw()

    def expand_to(self, node_id: str) -> None:
        """Open every collapsed ancestor so `node_id` is visible."""
        assert self.tree is not None
        hidden = set(self.tree.lineage(node_id)[:-1]) & self.collapsed
        if hidden:  # redraw only when something opens
            self.collapsed -= hidden
            self.redraw()

    def redraw(self) -> None:
        with self._lock:
            self._redraw()

    def _redraw(self) -> None:
        assert self.plan is not None and self.tree is not None
        for handle in self._handles + self._near_selection:
            handle.remove()
        self._handles, self._near_selection = [], []
        self.current = layout(self.tree, self.collapsed)
        nodes = self.plan.nodes
        scene = self.server.scene
        size = (0.02, 0.7 * SCALE, 0.45 * SCALE)
        labelled = self.labelled_all = len(self.current.positions) <= LABEL_LIMIT
        branch = {node_id for node_id, _ in self.plan.expected_path()}
        for node_id in self.current.positions:
            node = nodes[node_id]
            kind = node.kind
            colour = rgb(KIND_COLOURS[kind]) if kind in KIND_COLOURS else OPEN_COLOUR
            box = scene.add_box(
                f"{PREFIX}/nodes/{node_id}", color=colour, dimensions=size,
                position=self.world(node_id),
            )  # fmt: skip
            box.on_click(self._clicked(node_id))
            self._handles.append(box)
            hidden = self.current.hidden_below.get(node_id)
            named = labelled or node_id in branch
            if named or hidden:
                text = short(node.action, kind) if named else ""
                if hidden:
                    text += f"  [+{hidden}]"
                self._handles.append(self._label(node_id, text.strip()))
        self._draw_edges(labelled)

    def _label(self, node_id: str, text: str, name: str = "labels") -> viser.LabelHandle:
        x, y, z = self.world(node_id)
        return self.server.scene.add_label(
            f"{PREFIX}/{name}/{node_id}", text, position=(x - 0.02, y, z + 0.3 * SCALE),
            anchor="bottom-center", font_screen_scale=0.7,
        )  # fmt: skip

    def _draw_edges(self, labelled: bool) -> None:
        assert self.current is not None
        tree_edges = [e for e in self.current.edges if not e.shared]
        shared = [e for e in self.current.edges if e.shared]
        for name, edges, colour, width in (
            ("edges", tree_edges, (90, 90, 90), 2.0),
            ("shared", shared, (170, 170, 220), 1.0),
        ):
            if not edges:
                continue
            points = np.array([[self.world(e.parent), self.world(e.child)] for e in edges])
            self._handles.append(
                self.server.scene.add_line_segments(
                    f"{PREFIX}/{name}",
                    points,
                    colour,
                    thickness=width,
                    thickness_units="screen",
                )  # fmt: skip
            )
        if labelled:
            for e in tree_edges:
                if e.outcome is None:
                    continue
                a, b = np.array(self.world(e.parent)), np.array(self.world(e.child))
                mid = (a + b) / 2 - np.array([0.03, 0.0, 0.0])
                self._handles.append(
                    self.server.scene.add_label(
                        f"{PREFIX}/outcomes/{e.parent}-{e.child}",
                        e.outcome,
                        position=tuple(mid),
                        anchor="center-center",
                        font_screen_scale=0.6,
                    )  # fmt: skip
                )

    def highlight(self, node_id: str) -> None:
        with self._lock:
            self._highlight_node(node_id)

    def _highlight_node(self, node_id: str) -> None:
        if self.current is None or node_id not in self.current.positions:
            return
        self._label_selection(node_id)
        x, y, z = self.world(node_id)
        if self._highlight is None:
            self._highlight = self.server.scene.add_box(
                f"{PREFIX}/selected", color=SELECTED, dimensions=(0.01, 0.9 * SCALE, 0.65 * SCALE),
                position=(x + 0.03, y, z),
            )  # fmt: skip
        else:
            self._highlight.position = (x + 0.03, y, z)

    def _label_selection(self, node_id: str) -> None:
        """In a crowded tree, name the selected node and its children."""
        for handle in self._near_selection:
            handle.remove()
        self._near_selection = []
        if self.labelled_all or self.plan is None or self.current is None:
            return
        nodes = self.plan.nodes
        around = [node_id] + [k.node for k in nodes[node_id].children]
        for n in around:
            if n in self.current.positions:
                text = short(nodes[n].action, nodes[n].kind)
                self._near_selection.append(self._label(n, text, "near"))

    def _clicked(self, node_id: str) -> Callable[[Any], None]:
        def handler(_: Any) -> None:
            self.on_select(node_id)

        return handler
