"""Repair: a new conditional plan from what was observed, when the person surprised the plan.

The executor hands a `Surprise` at a node to a `Repairer`; it builds the
observed state (the node's state changed by the surprise), plans every
contingency again from it, stores the new plan, and returns a `Repair` the
executor continues on. The session keeps the repair as an event of kind
`repair` whose evidence names the old plan, the observed state and the new
plan, so a review can switch plans where the execution did.
"""

from __future__ import annotations

from collections.abc import Callable

from app.execution.events import Repair, RepairFailed
from app.execution.surprises import Surprise
from planner.plan.model import Plan, PlanNode
from planner.planning import plan_scenario
from planner.scenario.model import Scenario
from planner.search.errors import DeadEnd


class Repairer:
    """Plans again from observed states of `scenario`; `keep(plan)` stores each new plan
    and returns its hash (the session store's `add_plan`)."""

    def __init__(
        self, scenario: Scenario, keep: Callable[[Plan], str], *, workers: int = 1
    ) -> None:
        self.scenario = scenario
        self.keep = keep
        self.workers = workers
        self.repairs: list[Repair] = []

    def repair(self, node: PlanNode, surprise: Surprise) -> tuple[Repair, str]:
        """The repair after `surprise` at `node`, and the new plan's hash."""
        observed = surprise.apply(frozenset(node.state))
        try:
            result = plan_scenario(self.scenario, workers=self.workers, start=observed)
        except DeadEnd as err:
            raise RepairFailed(f"no plan after '{surprise}': {err}") from None
        except ValueError as err:
            # A state the domain cannot hold (a slot the part does not have) or a
            # motion the robot cannot make from it.
            raise RepairFailed(f"cannot plan after '{surprise}': {err}") from None
        plan = result.plan
        repair = Repair(plan, observed, surprise.words(), float(plan.statistics["plan_s"]))
        self.repairs.append(repair)
        return repair, self.keep(plan)
