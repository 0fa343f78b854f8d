"""A tidy 2D layout of a plan DAG, with collapsible subtrees.

The DAG is drawn as its breadth-first spanning tree: each node once, under the
parent that reaches it first; an edge into a node that already has a parent is a
"shared" edge (drawn thinner). Leaves get consecutive columns, a parent sits
above the middle of its children, depth is the row. Pure: no viser.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from planner.plan.model import Plan

COLUMN = 1.0  # layout units between neighbouring leaves
ROW = 1.6  # between depths


@dataclass(frozen=True)
class Edge:
    parent: str
    child: str
    outcome: str | None
    shared: bool  # the child is drawn under another parent


@dataclass
class TreeLayout:
    positions: dict[str, tuple[float, float]]  # visible node -> (x, y); y grows downwards
    edges: list[Edge]
    collapsed: set[str]  # visible nodes whose subtree is hidden
    hidden_below: dict[str, int] = field(default_factory=dict)  # collapsed -> hidden count

    @property
    def width(self) -> float:
        xs = [x for x, _ in self.positions.values()]
        return max(xs) - min(xs) if xs else 0.0


@dataclass
class SpanningTree:
    root: str
    children: dict[str, list[tuple[str | None, str]]]  # tree children with outcome labels
    parent: dict[str, str]
    shared: list[Edge]  # DAG edges not in the tree
    depth: dict[str, int]

    @classmethod
    def of(cls, plan: Plan) -> SpanningTree:
        nodes = plan.nodes
        root = plan.root
        children: dict[str, list[tuple[str | None, str]]] = {root: []}
        parent: dict[str, str] = {}
        depth = {root: 0}
        shared: list[Edge] = []
        queue = deque([root])
        while queue:
            node_id = queue.popleft()
            for child in nodes[node_id].children:
                kid = child.node
                if kid in depth:
                    shared.append(Edge(node_id, kid, child.outcome, True))
                    continue
                depth[kid] = depth[node_id] + 1
                parent[kid] = node_id
                children[kid] = []
                children[node_id].append((child.outcome, kid))
                queue.append(kid)
        return cls(root, children, parent, shared, depth)

    def lineage(self, node_id: str) -> list[str]:
        """Root first, `node_id` last."""
        out = [node_id]
        while out[-1] in self.parent:
            out.append(self.parent[out[-1]])
        return out[::-1]

    def subtree_size(self, node_id: str) -> int:
        count, stack = 0, [node_id]
        while stack:
            n = stack.pop()
            count += 1
            stack.extend(kid for _, kid in self.children[n])
        return count

    def default_collapsed(self, plan: Plan, budget: int = 60) -> set[str]:
        """Collapse so about `budget` nodes show: the expected branch stays open, then
        the shallowest nodes first."""
        keep: set[str] = set()
        for on_branch, _ in plan.expected_path():
            # The expected child may hang under another parent in the spanning tree.
            keep.update(self.lineage(on_branch))
        shown = set(keep)
        for node_id in keep:
            shown.update(k for _, k in self.children[node_id])
        order = sorted(self.depth, key=lambda n: (self.depth[n], n))
        for n in order:
            if len(shown) >= budget:
                break
            if n in shown:  # a node opens all its children or none
                shown.update(k for _, k in self.children[n])
        return {n for n in shown if any(k not in shown for _, k in self.children[n])}


def layout(tree: SpanningTree, collapsed: set[str]) -> TreeLayout:
    positions: dict[str, tuple[float, float]] = {}
    edges: list[Edge] = []
    hidden: dict[str, int] = {}
    next_column = [0.0]

    def place(node_id: str) -> float:
        # Iterative depth-first placement would be longer; depth is at most ~100.
        kids = [] if node_id in collapsed else tree.children[node_id]
        if not kids:
            x = next_column[0]
            next_column[0] += COLUMN
        else:
            xs = []
            for outcome, kid in kids:
                xs.append(place(kid))
                edges.append(Edge(node_id, kid, outcome, False))
            x = (xs[0] + xs[-1]) / 2
        positions[node_id] = (x, tree.depth[node_id] * ROW)
        if node_id in collapsed and tree.children[node_id]:
            hidden[node_id] = tree.subtree_size(node_id) - 1
        return x

    place(tree.root)
    edges += [e for e in tree.shared if e.parent in positions and e.child in positions]
    shown_collapsed = {n for n in collapsed if n in positions and tree.children[n]}
    return TreeLayout(positions, edges, shown_collapsed, hidden)
