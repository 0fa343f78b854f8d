"""The arm paths of a plan: each robot actuation node gets the motion it executes.

Where an arm stands follows from the state: a free arm is at home; an arm holding
a loose part is at that part's grasp; an arm holding a part it has attached is at
the assembly's work point (the root's connection point nearest to it), or still
at its grasp if the other arm brought the assembly to it. So

- `hold(M,P)`: home to the grasp of P;
- `attach(M,Q,C)`: the grasp of the held part to the work point of Q's assembly;
- `unhold(M)`: from there back home.
"""

from __future__ import annotations

from planner.feasibility.arms import joint_names
from planner.feasibility.checks import BenchChecks
from planner.plan import Motion, Plan
from planner.vocabulary import Action, Attach, Hands, Hold, Unhold

DECIMALS = 4  # 0.1 mrad: far below what the arm can resolve; keeps plan files small



def add_motions(plan: Plan, checks: BenchChecks) -> int:
    """Adds its `motion` to every actuation node of `plan`; returns how many distinct
    motions the plan uses."""
    nodes = [
        (node, _endpoints(node.action, node.state, checks))
        for node in plan.nodes.values()
        if node.kind == "actuation" and node.action is not None
    ]
    # Part-to-part motions are asked for all at once, so the pool plans them side by side.
    checks.prefetch_moves(
        (arm, start, goal) for _, (arm, start, goal) in nodes if start is not None and goal
    )
    seen: dict[tuple[str, str | None, str | None], list[list[float]]] = {}
    for node, (arm, start, goal) in nodes:
        if (arm, start, goal) not in seen:
            path = checks.move(arm, start, goal)
            seen[(arm, start, goal)] = [[round(v, DECIMALS) for v in q] for q in path]
        node.motion = Motion(arm=arm, joints=joint_names(arm), path=seen[(arm, start, goal)])
    return len(seen)


def _endpoints(
    action: Action, state: list[str], checks: BenchChecks
) -> tuple[str, str | None, str | None]:
    """(arm, where it starts, where it ends) as part ids whose work point it is at."""
    hands = Hands.of(state)

    def root(part: str) -> str:
        while part in hands.attached:
            part = hands.attached[part][0]
        return part

    def work_point(arm: str, held: str, onto: str) -> str:
        # At the assembly if the arm reaches it; else the other arm brings it over.
        r = root(onto)
        return r if checks.reach(arm, r).reachable else held

    match action:
        case Hold(arm, part):
            return arm, None, part
        case Attach(arm, onto, _):
            held = hands.holding[arm]
            return arm, held, work_point(arm, held, onto)
        case Unhold(arm):
            held = hands.holding[arm]
            return arm, work_point(arm, held, held), None
    raise ValueError(f"no motion for actuation {action}")
