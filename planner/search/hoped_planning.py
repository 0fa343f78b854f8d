"""Planning on the reach answers hoped for, while the check processes decide them.

A geometric reach answer waits for a path from home (`BenchChecks.answers`): on a
small bench the check processes take longer to decide them all than the planning
process takes to ground the program of the answers hoped for (every pair whose IK
meets its grasp counted reachable: on the paper's benches, every one is), and the
planning process had nothing to do meanwhile. Now it plans on the hoped answers in
a thread while the decisions come in. If they are the hoped ones, the problem is
the same, so is its ground program and every solve: the plan is the one planning
would have made after them, found sooner. If not, that planning is abandoned and
planning starts again from the answers decided.

What planning tells the rest waits for the answers: the motions it starts need
the decided reach goals (`BenchChecks.at`), and a first branch is executable only
once its reach is known, so it counts from then.
"""

from __future__ import annotations

import threading
from concurrent.futures import Future

from planner.search.dag import DagNode
from planner.search.hcp import ConditionalPlanner
from planner.vocabulary import State


class HopedPlanning:
    """`planner.build(root)` in a thread of its own, its `on_planned` and
    `on_first_branch` held back until `confirm`."""

    def __init__(self, planner: ConditionalPlanner, root: State) -> None:
        self.planner = planner
        self._told_planned = planner.on_planned
        self._told_first = planner.on_first_branch
        self._lock = threading.Lock()  # a callback runs in one thread at a time
        self._confirmed = False
        self._planned: list[DagNode] = []  # planned before the answers were known
        self._first: dict[State, DagNode] | None = None  # the DAG when the branch came
        planner.on_planned = self._planned_meanwhile
        planner.on_first_branch = self._first_meanwhile
        self._root: Future[State] = Future()
        self._thread = threading.Thread(
            target=self._build, args=(root,), name="tandem-hoped-planning", daemon=True
        )
        self._thread.start()

    def _build(self, root: State) -> None:
        try:
            self._root.set_result(self.planner.build(root))
        except BaseException as err:  # noqa: BLE001 - raised again by `result`
            self._root.set_exception(err)

    def confirm(self) -> None:
        """The answers are the hoped ones: what was held back is told now."""
        with self._lock:
            self._confirmed = True
            if self._first is not None and self._told_first is not None:
                self._told_first(self._first)
            if self._planned and self._told_planned is not None:
                self._told_planned(self._planned)
            self._planned = []

    @property
    def planning(self) -> bool:
        """Whether the plan is still being built (in its own thread)."""
        return self._thread.is_alive()

    def result(self) -> State:
        """The root, once the plan is built (`ConditionalPlanner.build`'s errors too)."""
        self._thread.join()
        return self._root.result()

    def abandon(self) -> None:
        """Stops planning on answers that were not the decided ones, and waits for it
        to stop (its worker processes and threads too); nothing once it is done."""
        if self._thread.is_alive():
            self.planner.cancel()
            self._thread.join()

    def _planned_meanwhile(self, nodes: list[DagNode]) -> None:
        with self._lock:
            if not self._confirmed:
                self._planned.extend(nodes)
            elif self._told_planned is not None:
                self._told_planned(nodes)

    def _first_meanwhile(self, nodes: dict[State, DagNode]) -> None:
        with self._lock:
            if not self._confirmed:
                self._first = nodes
            elif self._told_first is not None:
                self._told_first(nodes)
