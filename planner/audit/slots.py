"""Audit that every stored arm motion goes where its branch's state says, on the real Baxter.

`audit_motion` judges a plan file alone; this needs the bench geometry (the
scenario the plan was made for) and forward kinematics. The expected places come
from the state and the slot geometry of scene.py, not from the code that made the
motions: `hold(M,P)` ends over P's work point; `attach(M,Q,C)` ends over the site
of Q's point C as the state places Q (or, when the other arm holds Q's assembly,
the arm may stay at its grasp: that arm brings the assembly over); `unhold(M)`
starts where the held part was attached. "Over" means the gripper endpoint within
`POS_TOL` of the top-down grasp position, the tolerance inverse kinematics met.
A node whose motion assumes other real points than its names (`slots`: the robot
took another free slot on the way, planner.feasibility.slot_map) is judged through that map,
which must be one to one and put an attach on a free point.
"""

from __future__ import annotations

import math
from typing import Any

from planner.feasibility.grasp_ik import POS_TOL
from planner.feasibility.reach import World
from planner.feasibility.scene import site_of
from planner.feasibility.slot_map import SlotMap
from planner.plan.model import SLOTS
from planner.scenario.model import Scenario
from planner.vocabulary import Attach, Hands, Hold, TermError, Unhold, parse_action

Point = tuple[float, float, float]


def slot_problems(plan: dict[str, Any], scenario: Scenario) -> list[tuple[str, str]]:
    """(node id, message) for every motion of `plan` that misses its place."""
    nodes = plan.get("nodes")
    facts = plan.get("facts")
    if not isinstance(nodes, dict) or not isinstance(facts, list):
        return []
    out: list[tuple[str, str]] = []
    with World(scenario) as world:
        for node_id, node in nodes.items():
            message = _check(world, node, [str(f) for f in facts])
            if message:
                out.append((node_id, message))
    return out


def _check(world: World, node: dict[str, Any], facts: list[str]) -> str:
    motion = node.get("motion")
    if node.get("kind") != "actuation" or not isinstance(motion, dict):
        return ""
    try:
        action = parse_action(str(node.get("action")))
    except TermError:
        return ""  # the main audit names a bad action
    arm, path = motion.get("arm"), motion.get("path")
    if not (isinstance(arm, str) and isinstance(path, list) and path):
        return ""  # a malformed motion: audit_motion names it
    raw = node.get(SLOTS) or {}
    if not (isinstance(raw, dict) and all(isinstance(m, dict) for m in raw.values())):
        return "slots is not a map of part -> {name: point}"
    slots = SlotMap(facts, raw)
    if slots.problems():
        return slots.problems()[0]
    state = [str(f) for f in node.get("state", [])]
    if isinstance(action, Attach):
        real = slots.real(action.onto, action.slot)
        if real not in slots.free(action.onto, state):
            return f"attach at {action.onto}'s {real}, which its slot map says is taken"
    action = slots.action(action)
    hands = Hands.of(slots.state(state))

    def grasp(part: str) -> Point:
        box = world.scene.parts[part]
        x, y, z = world.ik.grasp_poses(box, arm)[0][0]
        return (x, y, z)

    def slot(onto: str, point: str) -> tuple[str, Point]:
        site = site_of(hands.attached, onto, point)
        return f"the site of {onto}'s {point} ({site})", world.site_target(site)

    match action:
        case Hold(_, part):
            return _miss(world, arm, path[-1], "ends", [(f"the grasp of {part}", grasp(part))])
        case Attach(_, onto, point):
            held = hands.holding.get(arm)
            places = [slot(onto, point)]
            other_holds = set(hands.holding.values()) - {held}
            root = site_of(hands.attached, onto, point).part
            if held is not None and root in other_holds:
                places.append((f"the grasp of {held}", grasp(held)))
            return _miss(world, arm, path[-1], "ends", places)
        case Unhold(_):
            held = hands.holding.get(arm)
            if held is None:
                return ""  # the main audit names an impossible unhold
            if held not in hands.attached:
                return _miss(world, arm, path[0], "starts", [(f"the grasp of {held}", grasp(held))])
            places = [slot(*hands.attached[held])]
            root = site_of(hands.attached, *hands.attached[held]).part
            if root in set(hands.holding.values()) - {held}:
                places.append((f"the grasp of {held}", grasp(held)))
            return _miss(world, arm, path[0], "starts", places)
    return ""


def _miss(
    world: World, arm: str, q: list[float], verb: str, places: list[tuple[str, Point]]
) -> str:
    """Empty if the gripper at `q` is over one of `places`, else a message for the first."""
    at = world.endpoint(arm, [float(v) for v in q])
    if any(math.dist(at, xyz) <= POS_TOL for _, xyz in places):
        return ""
    name, xyz = places[0]
    return f"{arm} motion {verb} {math.dist(at, xyz) * 100:.1f} cm from {name}"
