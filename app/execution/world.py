"""The world at a plan node: where each part is drawn and where each arm stands.

Pure functions of the plan and the bench geometry (no viser), so they are tested
without a browser. Attached parts stand on their assembly at the connection point;
held parts float a little above where they were taken; parts in the human's hands
are drawn just past the bench's human-side edge, wherever the scenario puts it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from planner.feasibility.arms import HOME
from planner.feasibility.scene import BENCH_TOP_Z, PartBox
from planner.plan.model import PlanNode
from planner.vocabulary import Hands

LIFT = 0.12  # metres above the bench for a part held by an arm
# The human holds parts this far past the bench's human-side edge (a forearm's
# reach over it), and this high above the bench top.
HANDS_PAST_EDGE = 0.15
HANDS_Z = BENCH_TOP_Z + 0.25


def hands_x(human_edge_x: float) -> float:
    """Where the human holds parts (x), past the bench's edge at `human_edge_x`."""
    return human_edge_x + HANDS_PAST_EDGE


@dataclass(frozen=True)
class Placement:
    """Centre of a part's box and who holds it (an arm, "human", or None)."""

    x: float
    y: float
    z: float
    holder: str | None = None
    attached_to: str | None = None


@dataclass(frozen=True)
class WorldView:
    parts: dict[str, Placement]
    arms: dict[str, list[float]]  # arm -> 7 joint values


def place_parts(
    boxes: dict[str, PartBox], state: list[str], *, human_edge_x: float
) -> dict[str, Placement]:
    """Each part's box centre in `state`; the bench's human-side edge is at `human_edge_x`."""
    hands = Hands.of(state)
    attached, human = hands.attached, hands.human
    held_by = {part: arm for arm, part in hands.holding.items()}
    out: dict[str, Placement] = {}

    def place(pid: str) -> Placement:
        if pid in out:
            return out[pid]
        box = boxes[pid]
        if pid in attached:
            onto, point = attached[pid]
            base = place(onto)
            x, y = base.x, base.y
            sites = boxes[onto].sites()
            if onto not in attached and point in sites:
                # Offsets of the site from the part's own centre, wherever it is drawn.
                x += sites[point][0] - boxes[onto].x
                y += sites[point][1] - boxes[onto].y
            z = base.z + boxes[onto].size[2] / 2 + box.size[2] / 2
            result = Placement(x, y, z, held_by.get(pid, base.holder), onto)
        elif pid in held_by:
            result = Placement(box.x, box.y, BENCH_TOP_Z + box.size[2] / 2 + LIFT, held_by[pid])
        elif pid in human:
            result = Placement(hands_x(human_edge_x), box.y, HANDS_Z, "human")
        else:
            result = Placement(box.x, box.y, BENCH_TOP_Z + box.size[2] / 2)
        out[pid] = result
        return result

    for pid in boxes:
        place(pid)
    return out


def arms_at(nodes: Mapping[str, PlanNode], lineage: list[str]) -> dict[str, list[float]]:
    """Each arm at the end of its latest motion along `lineage` (root first, the
    selected node last, its own motion included); home if it has not moved."""
    arms = {arm: list(q) for arm, q in HOME.items()}
    for node_id in lineage:
        motion = nodes[node_id].motion
        if motion and motion.path:
            arms[motion.arm] = list(motion.path[-1])
    return arms


def world_at(
    nodes: Mapping[str, PlanNode],
    lineage: list[str],
    boxes: dict[str, PartBox],
    *,
    human_edge_x: float,
) -> WorldView:
    """The world as the selected node (last of `lineage`) leaves it: its own action
    done, so clicking `hold(left,leg1)` shows leg1 in the left hand."""
    node = nodes[lineage[-1]]
    after = node.state
    if node.kind == "actuation" and node.children:
        after = nodes[node.children[0].node].state
    return WorldView(place_parts(boxes, after, human_edge_x=human_edge_x), arms_at(nodes, lineage))
