"""The selected node, under the tree: what it does, and where to go from it.

It follows the selection announced on `Events` (`NodeSelected`, whoever made
it: a click in the tree, an execution, a review) and drives the stage to go
to a child, to the parent, or to fold the branch below. What it shows for a
node is `node_view`, a plain function. See stage.py for the panel pattern.
"""

from __future__ import annotations

from dataclasses import dataclass

import viser

from app.dashboard.node_details import details_markdown
from app.dashboard.stage import Events, NodeSelected, PlanChanged, Stage

NOTHING_SELECTED = "Click a node of the plan tree."


@dataclass(frozen=True)
class NodeView:
    """The panel for one node: its details, whether its branch can be folded,
    its parent (None at the root), and each child by the label of its button."""

    details: str
    foldable: bool
    parent: str | None
    children: dict[str, str]


def node_view(selected: NodeSelected) -> NodeView:
    """A child's button says its outcome ("next" after a deterministic action)."""
    node = selected.node
    children = {(k.outcome or "next"): k.node for k in node.children}
    return NodeView(
        details_markdown(selected.node_id, node),
        foldable=bool(node.children),
        parent=selected.parent,
        children=children,
    )


class NodePanel:
    def __init__(self, gui: viser.GuiApi, stage: Stage, events: Events) -> None:
        self.gui = gui
        self.stage = stage
        self.selected: str | None = None
        self.view: NodeView | None = None
        self.folder = gui.add_folder("Selected node")
        with self.folder:
            self.details = gui.add_markdown(NOTHING_SELECTED)
            self.toggle_button = gui.add_button("Collapse / expand", disabled=True)
            self.toggle_button.on_click(lambda _: self._toggle())
            self.parent_button = gui.add_button("Parent", disabled=True)
            self.parent_button.on_click(lambda _: self._to_parent())
            # One group whose options change: a group rebuilt per selection
            # leaves a removal in every page's replay buffer.
            self.children_group = gui.add_button_group("Go to", ("next",), visible=False)
        self.children: dict[str, str] = {}
        self.children_group.on_click(lambda e: self._go_to(e.target.value))
        events.subscribe(NodeSelected, self._selected)
        events.subscribe(PlanChanged, self._plan_changed)

    def _plan_changed(self, message: PlanChanged) -> None:
        if message.plan is None:  # no plan: nothing is selected
            self.selected = self.view = None
            self.details.content = NOTHING_SELECTED
            self.toggle_button.disabled = self.parent_button.disabled = True
            self._child_buttons({})

    def _selected(self, message: NodeSelected) -> None:
        view = node_view(message)
        self.selected, self.view = message.node_id, view
        self.details.content = view.details
        self.toggle_button.disabled = not view.foldable
        self.parent_button.disabled = view.parent is None
        self._child_buttons(view.children)

    def _child_buttons(self, children: dict[str, str]) -> None:
        self.children = children
        if children:
            self.children_group.options = tuple(children)
        self.children_group.visible = bool(children)

    def _go_to(self, outcome: str) -> None:
        node = self.children.get(outcome)
        if node is not None:
            self.stage.go_to(node)

    def _toggle(self) -> None:
        if self.selected is not None:
            self.stage.toggle(self.selected)

    def _to_parent(self) -> None:
        if self.view is not None and self.view.parent is not None:
            self.stage.select(self.view.parent)

    def close(self) -> None:
        """Nothing runs in the panel's own threads."""
