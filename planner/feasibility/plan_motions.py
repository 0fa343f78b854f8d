"""The arm paths of a plan: each robot actuation node gets the motion it executes.

Where an arm stands follows from the state: a free arm is at home; an arm holding
a loose part is at that part's grasp; an arm holding a part it has attached is at
the site of the slot that part went to (scene.py: slots follow the assembly), or
still at its grasp if it cannot reach that site (the other arm holds the assembly
and brought it over). So

- `hold(M,P)`: home to the grasp of P;
- `attach(M,Q,C)`: the grasp of the held part to the site of Q's point C;
- `unhold(M)`: from there back home.

The point C is the one the node's slot map says C stands for: the identity, unless
on the way from the root the robot took another free slot because its arm could
not reach the one named (slot_map.robot_choice); such nodes keep the map (`slots`,
and the node that chose its `robot_slot`).
`retarget` answers for one action in one state: the executor asks it when the
world's slots differ from those a node assumes (the human used another one).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator

from planner.feasibility.arms import joint_names
from planner.feasibility.checks import BenchChecks, Place
from planner.feasibility.scene import Site, site_of
from planner.feasibility.slot_map import SlotMap, robot_choice
from planner.plan.model import Motion, Plan, RobotSlot
from planner.vocabulary import Action, Attach, Hands, Hold, Unhold

DECIMALS = 4  # 0.1 mrad: far below what the arm can resolve; keeps plan files small

Endpoints = tuple[str, Place | None, Place | None]  # arm, from, to (None: home)


def add_motions(plan: Plan, checks: BenchChecks) -> int:
    """Adds its `motion` to every actuation node of `plan`; returns how many distinct
    motions the plan uses. A node whose motion assumes slots other than its names
    (the robot took another free slot on the way: planner.feasibility.slot_map) keeps that map
    as `slots`, and the node that chose keeps its choice as `robot_slot`."""
    # The slots' reach checks go to the pool side by side, before the walk below asks
    # for them one by one.
    checks.prefetch_sites(
        site for node in plan.nodes.values() for site in slot_sites(node.action, node.state)
    )
    maps, choices = _slot_maps(plan, checks)
    nodes = []
    for node_id, node in plan.nodes.items():
        slots = maps.get(node_id) or SlotMap(plan.facts)
        node.slots = None if slots.identity else slots.to_json()
        node.robot_slot = choices.get(node_id)
        if node.kind != "actuation" or node.action is None:
            continue
        action, state = slots.action(node.action), slots.state(node.state)
        nodes.append((node, endpoints(action, state, checks)))
    # Part-to-part motions are asked for all at once, so the pool plans them side by side.
    checks.prefetch_moves(
        (arm, start, goal) for _, (arm, start, goal) in nodes if start is not None and goal
    )
    seen: dict[Endpoints, Motion] = {}
    for node, ends in nodes:
        if ends not in seen:
            seen[ends] = _motion(ends, checks)
        # Nodes with the same endpoints share one motion: nothing changes a motion
        # once made (retargeting makes a new one), and copies cost 0.1 s on paper-05.
        node.motion = seen[ends]
    return len(seen)


def slot_sites(action: Action | None, state: list[str]) -> Iterator[tuple[str, Site]]:
    """The (arm, site) whose reach `endpoints` asks for, with the slots the plan names."""
    hands = Hands.of(state)
    match action:
        case Attach(arm, onto, point):
            yield arm, site_of(hands.attached, onto, point)
        case Unhold(arm) if hands.holding[arm] in hands.attached:
            onto, point = hands.attached[hands.holding[arm]]
            yield arm, site_of(hands.attached, onto, point)


def _slot_maps(plan: Plan, checks: BenchChecks) -> tuple[dict[str, SlotMap], dict[str, RobotSlot]]:
    """The slot map each node's motion assumes: the robot's choices on the way from the
    root (`robot_choice`), parents first, and the choices by node. A node reached with
    two maps keeps its first parent's (rare: five merges on paper-03 and -04 each);
    execution re-targets when it comes the other way."""

    def reaches(arm: str, site: Site) -> bool:
        return checks.reaches_site(arm, site)

    indegree: dict[str, int] = {}
    for node in plan.nodes.values():
        for child in node.children:
            indegree[child.node] = indegree.get(child.node, 0) + 1
    maps = {plan.root: SlotMap(plan.facts)}
    choices: dict[str, RobotSlot] = {}
    ready = deque([plan.root])
    while ready:
        node_id = ready.popleft()
        node = plan.nodes[node_id]
        slots = maps[node_id]
        if isinstance(node.action, Attach):
            chosen = slots.copy()
            choice = robot_choice(chosen, node.action, node.state, reaches)
            if choice is not None:
                slots = maps[node_id] = chosen  # its own motion goes to the chosen slot
                choices[node_id] = choice
        for child in node.children:
            maps.setdefault(child.node, slots)
            indegree[child.node] -= 1
            if indegree[child.node] == 0:
                ready.append(child.node)
    return maps, choices


def _motion(ends: Endpoints, checks: BenchChecks) -> Motion:
    arm, start, goal = ends
    path = [[round(v, DECIMALS) for v in q] for q in checks.move(arm, start, goal)]
    return Motion(arm=arm, joints=joint_names(arm), path=path)


def endpoints(action: Action, state: list[str], checks: BenchChecks) -> Endpoints:
    """(arm, where it starts, where it ends) of actuation `action` in `state`."""
    hands = Hands.of(state)

    def at_slot(arm: str, held: str, onto: str, point: str) -> Place:
        site = site_of(hands.attached, onto, point)
        return site if checks.reaches_site(arm, site) else held

    match action:
        case Hold(arm, part):
            return arm, None, part
        case Attach(arm, onto, point):
            held = hands.holding[arm]
            return arm, held, at_slot(arm, held, onto, point)
        case Unhold(arm):
            held = hands.holding[arm]
            if held in hands.attached:
                onto, point = hands.attached[held]
                return arm, at_slot(arm, held, onto, point), None
            return arm, held, None
    raise ValueError(f"no motion for actuation {action}")


def retarget(
    action: Action, state: list[str], real: Action, real_state: list[str], checks: BenchChecks
) -> Motion | None:
    """The motion of `real` in `real_state` (the world, where the branch's `action` in
    `state` names other slots), or None when the branch's motion goes there already."""
    ends = endpoints(real, real_state, checks)
    if ends == endpoints(action, state, checks):
        return None
    return _motion(ends, checks)
