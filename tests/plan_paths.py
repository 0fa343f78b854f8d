"""Paths of executions through plans, for the tests' assertions."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from typing import Any

from app.sessions.store import canonical_json
from planner.plan.model import Plan


def plan_hash(plan: Plan | Mapping[str, Any]) -> str:
    """sha256 of the canonical JSON of the plan."""
    return hashlib.sha256(canonical_json(plan).encode("utf-8")).hexdigest()


def is_plan_path(
    plan: Plan, path: Sequence[tuple[str, str | None]], *, complete: bool = True
) -> bool:
    """Whether `path` [(node, outcome)] follows the plan from its root.

    `complete`: it must end at a goal leaf; otherwise a prefix is enough.
    """
    nodes = plan.nodes
    if not path:
        return not complete
    if path[0][0] != plan.root:
        return False
    for (node_id, outcome), (next_id, _) in zip(path, path[1:], strict=False):
        node = nodes.get(node_id)
        if node is None or node.child(outcome) != next_id:
            return False
    last_id, last_outcome = path[-1]
    last = nodes.get(last_id)
    if last is None:
        return False
    if complete:
        return last.kind == "goal" and last_outcome is None and not last.children
    return True
