"""The motions of a plan, started while it is planned (geometric feasibility)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from planner.vocabulary import Attach

if TYPE_CHECKING:
    from planner.feasibility.checks import BenchChecks
    from planner.search.dag import DagNode


def motion_prefetch(
    checks: BenchChecks, first_branch_done: Callable[[], bool]
) -> Callable[[list[DagNode]], None]:
    """Starts the part-to-part motions of newly planned attach actions in the check
    pool while planning goes on; `add_motions` finds them there once the plan is built.

    Held back until the first branch exists (its planning comes first on a busy
    machine). A motion starts where a reach path ends, which the reach decision
    gives before the path is made (`BenchChecks.at`): planning never waits for one."""
    from planner.feasibility.plan_motions import endpoints, slot_sites

    backlog: list[DagNode] = []

    def prefetch(planned: list[DagNode]) -> None:
        if not checks.parallel:
            return  # one process: motions are made when the plan is built
        backlog.extend(n for n in planned if isinstance(n.action, Attach))
        if not backlog or not first_branch_done():
            return
        attaches = [
            (n, n.action, next(slot_sites(n.action, sorted(n.state))))
            for n in backlog
            if isinstance(n.action, Attach)  # (not any more: replanned after a dead end)
        ]
        backlog.clear()
        # An attach ends at a slot's site, whose reach is asked of the pool: `endpoints`
        # would otherwise check it here, in the planning loop. Until it is answered, the
        # node waits to be told again.
        checks.prefetch_sites(where for _, _, where in attaches)
        moves = []
        for node, action, where in attaches:
            if checks.site_known(*where):
                moves.append(endpoints(action, sorted(node.state), checks))
            else:
                backlog.append(node)
        checks.prefetch_moves((arm, a, b) for arm, a, b in moves if a is not None and b)

    return prefetch
