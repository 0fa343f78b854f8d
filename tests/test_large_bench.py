"""Plans of the paper's families, pinned: the tree statistics of the paper's 15
instances (declared feasibility), U10 and U18 stay what they were when the
planner's speed work for large benches began, and their plans pass the audit.

Changing how the search stores, shares or reuses its work must not change which
plans it finds; a change that does is a change of the plans, to be explained and
audited, and these numbers are updated with it.
"""

from __future__ import annotations

import pytest

from planner.audit.branches import audit
from planner.planning import PlanResult, plan_scenario
from planner.scenario import paper
from planner.scenario.loading import parse_scenario

# The paper's columns (planner.plan.model.tree_stats): leaves, the longest branch
# and its actions, the communication counts, decision nodes, the largest branching
# factor, the unfolded tree's nodes, goals, warnings, and the unexpected.
COLUMNS = ("L", "D", "A", "S", "C", "K", "O", "CF", "R", "DN", "BF", "N", "GE", "W", "X")

# Declared feasibility, 2 worker processes (history-free solves, window 8 on
# large benches, 4 on the others).
# fmt: off
PINNED: dict[str, tuple[int, ...]] = {
    #       L    D   A   S  C    K    O   CF    R    DN  BF      N    GE     W  X
    "U2": (34, 19, 9, 6, 4, 15, 3, 4, 19, 69, 3, 238, 35, 4, 0),
    "U3": (70, 26, 15, 7, 4, 31, 10, 6, 37, 141, 5, 652, 71, 36, 0),
    "U4": (130, 34, 21, 9, 4, 60, 18, 11, 71, 263, 7, 1343, 131, 135, 0),
    "U5": (214, 42, 27, 11, 4, 101, 26, 20, 121, 433, 9, 2440, 215, 312, 0),
    "U6": (314, 50, 33, 13, 4, 150, 38, 29, 179, 635, 11, 3845, 315, 641, 0),
    "P2": (62, 18, 6, 6, 6, 41, 1, 6, 47, 149, 3, 315, 63, 4, 0),
    "P3": (164, 21, 6, 7, 8, 131, 1, 10, 141, 433, 4, 883, 165, 6, 0),
    "P4": (408, 24, 6, 8, 10, 357, 1, 16, 373, 1133, 5, 2273, 409, 8, 0),
    "P5": (976, 27, 6, 9, 12, 895, 1, 26, 921, 2785, 6, 5547, 977, 10, 0),
    "P6": (2272, 30, 6, 10, 14, 2137, 1, 44, 2181, 6581, 7, 13069, 2273, 12, 0),
    "R2": (26, 19, 9, 6, 4, 11, 1, 4, 15, 52, 2, 137, 27, 2, 0),
    "R3": (26, 22, 12, 6, 4, 11, 1, 4, 15, 52, 2, 140, 27, 2, 0),
    "R4": (26, 25, 15, 6, 4, 11, 1, 4, 15, 52, 2, 143, 27, 2, 0),
    "R5": (26, 28, 18, 6, 4, 11, 1, 4, 15, 52, 2, 146, 27, 2, 0),
    "R6": (26, 31, 21, 6, 4, 11, 1, 4, 15, 52, 2, 149, 27, 2, 0),
    "U10": (922, 82, 57, 21, 4, 450, 102, 89, 539, 1859, 19, 14441, 923, 3805, 0),
    "U18": (3098, 146, 105, 37, 4, 1530, 326, 305, 1835, 6227, 35, 68753, 3099, 25909, 0),
}
# fmt: on


def _plan(name: str) -> PlanResult:
    family, n = name[0], int(name[1:])
    scenario = parse_scenario(paper.scenario_toml(family, n, "declared"), name)
    return plan_scenario(scenario, workers=2, cache_dir=":memory:")


def _columns(result: PlanResult) -> tuple[int, ...]:
    return tuple(int(result.plan.statistics[k]) for k in COLUMNS)


@pytest.mark.parametrize("name", [n for n in PINNED if n not in ("U10", "U18")])
def test_the_paper_instances_keep_their_tree(name: str) -> None:
    result = _plan(name)
    assert _columns(result) == PINNED[name]
    assert audit(result.plan.to_json()) == []


@pytest.mark.parametrize("name", ["U10", "U18"])
def test_large_benches_keep_their_tree_and_pass_the_audit(name: str) -> None:
    result = _plan(name)
    assert _columns(result) == PINNED[name]
    # The DAG shares states: far fewer distinct nodes than the unfolded tree has.
    assert result.plan.statistics["dag_nodes"] < result.plan.statistics["N"]
    assert audit(result.plan.to_json()) == []
