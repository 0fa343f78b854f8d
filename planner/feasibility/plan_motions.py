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

from dataclasses import dataclass
from typing import Any

from planner.domain_sim import parse_state
from planner.feasibility.checks import BenchChecks
from planner.feasibility.robot import JOINT_SUFFIXES
from planner.terms import constants, parse_term

DECIMALS = 4  # 0.1 mrad: far below what the arm can resolve; keeps plan files small


@dataclass(frozen=True)
class Hands:
    """Who holds what and what is attached where, read from a node's state."""

    holding: dict[str, str]  # arm -> part
    attached: dict[str, tuple[str, str]]  # part -> (onto, connection)
    human: frozenset[str]  # parts in the human's hands

    @classmethod
    def of(cls, state: list[str]) -> Hands:
        fluents, _ = parse_state(state)
        return cls(
            {f[1]: f[2] for f in fluents if f[0] == "holding"},
            {f[1]: (f[2], f[3]) for f in fluents if f[0] == "attached"},
            frozenset(f[1] for f in fluents if f[0] == "humanHoldingPart"),
        )


def joint_names(arm: str) -> list[str]:
    return [f"{arm}_{s}" for s in JOINT_SUFFIXES]


def add_motions(doc: dict[str, Any], checks: BenchChecks) -> int:
    """Adds `"motion"` to every actuation node of a `tandem-plan/1` document; returns
    how many distinct motions the plan uses."""
    seen: dict[tuple[str, str | None, str | None], list[list[float]]] = {}
    for node in doc["nodes"].values():
        if node["kind"] != "actuation":
            continue
        arm, start, goal = _endpoints(node["action"], node["state"], checks)
        if (arm, start, goal) not in seen:
            path = checks.move(arm, start, goal)
            seen[(arm, start, goal)] = [[round(v, DECIMALS) for v in q] for q in path]
        node["motion"] = {"arm": arm, "joints": joint_names(arm), "path": seen[(arm, start, goal)]}
    return len(seen)


def _endpoints(
    action: str, state: list[str], checks: BenchChecks
) -> tuple[str, str | None, str | None]:
    """(arm, where it starts, where it ends) as part ids whose work point it is at."""
    term = parse_term(action)
    args = constants(term) or ()
    hands = Hands.of(state)

    def root(part: str) -> str:
        while part in hands.attached:
            part = hands.attached[part][0]
        return part

    def work_point(arm: str, held: str, onto: str) -> str:
        # At the assembly if the arm reaches it; else the other arm brings it over.
        r = root(onto)
        return r if checks.reach(arm, r).reachable else held

    arm = args[0]
    if term.name == "hold":
        return arm, None, args[1]
    if term.name == "attach":
        held = hands.holding[arm]
        return arm, held, work_point(arm, held, args[1])
    if term.name == "unhold":
        held = hands.holding[arm]
        return arm, work_point(arm, held, held), None
    raise ValueError(f"no motion for actuation {action!r}")
