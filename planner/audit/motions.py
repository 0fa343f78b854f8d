"""Audit the arm motions of a plan: well formed, smooth, and continuous along branches.

Without a robot model: the geometry itself (collisions, limits) is re-checked by the
tests with the real Baxter. What a plan file alone can show is that each motion is
7 joints wide, moves no joint far between waypoints, and starts where the same arm's
previous motion on every branch into it ended (so execution never jumps). A branch
that comes into a node with another slot map than the node assumes (`slots`: it
was planned for the way in where the robot took other free slots; see
planner.feasibility.slot_map) is the one exception: the executor re-targets across it.
"""

from __future__ import annotations

from collections import deque
from typing import Any

from planner.feasibility.arms import JOINT_SUFFIXES
from planner.plan.model import ROBOT_SLOT, SLOTS

JOINTS = len(JOINT_SUFFIXES)
MAX_STEP = 0.06  # radians between waypoints: paths are densified to 0.05
TOLERANCE = 1e-3  # radians: the file rounds joints to 1e-4

Config = tuple[float, ...]


def motion_problems(nodes: dict[str, Any], root: str) -> list[tuple[str, str]]:
    """(node id, message) for every problem with the `motion` fields of a sound DAG."""
    out: list[tuple[str, str]] = []
    # Where each arm is when a node starts; None until some motion has moved it.
    arms_at: dict[str, dict[str, Config]] = {root: {}}
    order = _topological(nodes, root)
    # Asked once: per node it made the audit quadratic (U10: 15 s of 27 s).
    has_motions = any("motion" in n for n in nodes.values())
    for node_id in order:
        node = nodes[node_id]
        here = arms_at.get(node_id, {})
        after = dict(here)
        motion = node.get("motion")
        if node.get("kind") == "actuation" and motion is None:
            if has_motions:
                out.append((node_id, "actuation without a motion in a plan that has motions"))
        elif motion is not None:
            problem, arm, path = _shape(motion)
            if problem:
                out.append((node_id, problem))
            else:
                start = here.get(arm)
                if start is not None and _far(start, path[0]):
                    out.append((node_id, f"{arm} motion starts away from where the arm is"))
                after[arm] = path[-1]
        for child in node.get("children", []):
            if _slots_change(node, nodes.get(child["node"], {})):
                continue
            seen = arms_at.setdefault(child["node"], dict(after))
            for arm, q in after.items():
                if arm in seen and _far(seen[arm], q):
                    out.append((child["node"], f"{arm} is in two places, by two branches"))
    return out


def _slots_change(parent: dict[str, Any], child: dict[str, Any]) -> bool:
    """Does the edge bring another slot map than the child assumes (not its own choice)?"""
    if not isinstance(child, dict) or ROBOT_SLOT in child:
        return False
    return (parent.get(SLOTS) or {}) != (child.get(SLOTS) or {})


def _shape(motion: Any) -> tuple[str, str, list[Config]]:
    if not isinstance(motion, dict):
        return "motion is not an object", "", []
    arm, joints, raw = motion.get("arm"), motion.get("joints"), motion.get("path")
    if not isinstance(arm, str):
        return "motion has no arm", "", []
    if not (isinstance(joints, list) and len(joints) == JOINTS):
        return f"motion names {JOINTS} joints", arm, []
    if not (isinstance(raw, list) and raw):
        return "motion path is empty", arm, []
    path: list[Config] = []
    for q in raw:
        if not (isinstance(q, list) and len(q) == JOINTS):
            return f"motion waypoint is not {JOINTS} numbers", arm, []
        if not all(isinstance(v, int | float) for v in q):
            return f"motion waypoint is not {JOINTS} numbers", arm, []
        path.append(tuple(float(v) for v in q))
    for a, b in zip(path, path[1:], strict=False):
        if max(abs(x - y) for x, y in zip(a, b, strict=True)) > MAX_STEP:
            return f"motion jumps more than {MAX_STEP} rad between waypoints", arm, []
    return "", arm, path


def _far(a: Config, b: Config) -> bool:
    return max(abs(x - y) for x, y in zip(a, b, strict=True)) > TOLERANCE


def _topological(nodes: dict[str, Any], root: str) -> list[str]:
    """Parents before children (Kahn), over the nodes reachable from `root`."""
    indegree: dict[str, int] = {}
    reach = deque([root])
    seen = {root}
    while reach:
        node_id = reach.popleft()
        for child in nodes[node_id].get("children", []):
            indegree[child["node"]] = indegree.get(child["node"], 0) + 1
            if child["node"] not in seen:
                seen.add(child["node"])
                reach.append(child["node"])
    order = []
    ready = deque([root])
    while ready:
        node_id = ready.popleft()
        order.append(node_id)
        for child in nodes[node_id].get("children", []):
            indegree[child["node"]] -= 1
            if indegree[child["node"]] == 0:
                ready.append(child["node"])
    return order
