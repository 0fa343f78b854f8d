"""What the bench draws at a node: one rule for a run, a review and a click.

The bench at a node is the world as the node leaves it: its state (the fluents
true before its action), with its own action done when it is the robot's (a
click on `hold(left,leg1)` shows leg1 in the left hand), and with what its
answer made true once it was answered (after "Human holds foot2" the human
holds foot2). The way to the node is the one the execution or the review took
when the node is on its marked path (the arms stand where that way left them),
else the tree's. An execution moving through the plan and a person clicking the
same node in the tree both ask this module, with the same marked path, so the
two pictures cannot disagree. Pure: no viser.
"""

from __future__ import annotations

from collections.abc import Mapping

from app.dashboard.tree_layout import SpanningTree
from app.dashboard.tree_svg import Step
from app.execution.world import WorldView, arms_at, place_parts
from planner.feasibility.scene import PartBox
from planner.plan.model import PlanNode


def way_to(
    tree: SpanningTree, node_id: str, path: tuple[Step, ...]
) -> tuple[list[str], Step | None]:
    """The nodes from the root to `node_id` (root first) and the step of the path
    at it: the marked path up to its last pass through the node, else the
    tree's lineage and no step."""
    walked = [s.node for s in path]
    if node_id in walked:
        last = len(walked) - 1 - walked[::-1].index(node_id)
        if all(n in tree.depth for n in walked[: last + 1]):
            # A human's action kept at the node (a review) carries no answer: the
            # step is its last pass that was answered, if any was.
            at = [s for s in path[: last + 1] if s.node == node_id]
            answered = [s for s in at if s.outcome is not None]
            return walked[: last + 1], (answered or at)[-1]
    return tree.lineage(node_id), None


def state_after(nodes: Mapping[str, PlanNode], node_id: str, step: Step | None) -> list[str]:
    """The fluents the bench shows at `node_id`: after its answer when it has one,
    after its action when the robot acts, else before it."""
    node = nodes[node_id]
    if step is not None and step.outcome is not None:
        for child in node.children:
            if child.outcome == step.outcome and child.node in nodes:
                return nodes[child.node].state
    if node.kind == "actuation" and node.children and node.children[0].node in nodes:
        return nodes[node.children[0].node].state
    return node.state


def node_world(
    nodes: Mapping[str, PlanNode],
    tree: SpanningTree,
    node_id: str,
    path: tuple[Step, ...],
    boxes: dict[str, PartBox],
    *,
    human_edge_x: float,
) -> WorldView:
    """The world the bench draws at `node_id`, given the path marked on the tree."""
    lineage, step = way_to(tree, node_id, path)
    after = state_after(nodes, node_id, step)
    return WorldView(
        place_parts(boxes, after, human_edge_x=human_edge_x), arms_at(nodes, lineage)
    )
